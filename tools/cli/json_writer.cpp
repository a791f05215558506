#include "json_writer.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace pointfair::cli {

std::string json_quote(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

JsonObject& JsonObject::add(std::string_view key, double value) {
  if (!std::isfinite(value)) {
    members_.emplace_back(key, "null");
    return *this;
  }
  char buf[32];
  const auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, value);
  members_.emplace_back(key, std::string(buf, ptr));
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, long long value) {
  members_.emplace_back(key, std::to_string(value));
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, bool value) {
  members_.emplace_back(key, value ? "true" : "false");
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, std::string_view value) {
  members_.emplace_back(key, json_quote(value));
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, const JsonObject& value) {
  members_.emplace_back(key, value.str());
  return *this;
}

JsonObject& JsonObject::add(std::string_view key, const std::vector<JsonObject>& values) {
  std::string text = "[";
  for (std::size_t i = 0; i < values.size(); ++i) text += (i > 0 ? ", " : "") + values[i].str();
  members_.emplace_back(key, text + "]");
  return *this;
}

std::string JsonObject::str() const {
  std::string out = "{";
  for (std::size_t i = 0; i < members_.size(); ++i) {
    if (i) out += ", ";
    out += json_quote(members_[i].first) + ": " + members_[i].second;
  }
  return out + "}";
}

}  // namespace pointfair::cli
