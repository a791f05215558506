#pragma once
// A run summary as a JSON object, built member by member in the order the members are added
// (nlohmann-json holds and prints it; non-finite numbers print as null). The summaries are
// one line, with ", " between members and ": " after keys, as they have always been printed.
#include <cstddef>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace pointfair::cli {

class JsonObject {
 public:
  JsonObject();
  ~JsonObject();
  JsonObject(const JsonObject& other);
  JsonObject(JsonObject&& other);
  JsonObject& operator=(const JsonObject& other);
  JsonObject& operator=(JsonObject&& other) noexcept;

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
  /// The object on one line. Bytes of a string that are not UTF-8 print as U+FFFD.
  std::string str() const;

 private:
  // The nlohmann::ordered_json behind it, kept out of this header so that nlohmann-json stays
  // a private dependency of the command-line support library.
  struct Members;
  std::unique_ptr<Members> members_;
};

}  // namespace pointfair::cli
