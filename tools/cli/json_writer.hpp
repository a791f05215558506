#pragma once
// A minimal JSON object writer for run summaries (strings escaped, non-finite numbers as null).
#include <string>
#include <string_view>
#include <vector>

namespace pointfair::cli {

class JsonObject {
 public:
  JsonObject& add(std::string_view key, double value);
  JsonObject& add(std::string_view key, long long value);
  JsonObject& add(std::string_view key, int value) { return add(key, static_cast<long long>(value)); }
  JsonObject& add(std::string_view key, std::size_t value) { return add(key, static_cast<long long>(value)); }
  JsonObject& add(std::string_view key, bool value);
  JsonObject& add(std::string_view key, std::string_view value);
  JsonObject& add(std::string_view key, const char* value) { return add(key, std::string_view(value)); }
  JsonObject& add(std::string_view key, const JsonObject& value);
  /// An array of objects.
  JsonObject& add(std::string_view key, const std::vector<JsonObject>& values);
  std::string str() const;

 private:
  std::vector<std::pair<std::string, std::string>> members_;
};

std::string json_quote(std::string_view text);

}  // namespace pointfair::cli
