#include "json_writer.hpp"

#include <cmath>
#include <utility>

#include <nlohmann/json.hpp>

namespace pointfair::cli {

using Json = nlohmann::ordered_json;

struct JsonObject::Members {
  Json value = Json::object();
};

namespace {

// nlohmann prints compactly ({"a":1,"b":2}) or over several lines; the summaries are read by
// scripts that grep for '"key": value', so objects and arrays get ", " and ": " here and every
// scalar is printed by nlohmann (escapes, numbers, null for NaN and infinities).
void write(const Json& value, std::string& out) {
  if (value.is_object()) {
    out += '{';
    bool first = true;
    for (const auto& [key, member] : value.items()) {
      if (!first) out += ", ";
      first = false;
      out += Json(key).dump(-1, ' ', false, Json::error_handler_t::replace);
      out += ": ";
      write(member, out);
    }
    out += '}';
  } else if (value.is_array()) {
    out += '[';
    for (std::size_t i = 0; i < value.size(); ++i) {
      if (i > 0) out += ", ";
      write(value[i], out);
    }
    out += ']';
  } else {
    out += value.dump(-1, ' ', false, Json::error_handler_t::replace);
  }
}

}  // namespace

JsonObject::JsonObject() : members_(std::make_unique<Members>()) {}
JsonObject::~JsonObject() = default;
JsonObject::JsonObject(const JsonObject& other) : members_(std::make_unique<Members>(*other.members_)) {}
JsonObject::JsonObject(JsonObject&& other) : members_(std::exchange(other.members_, std::make_unique<Members>())) {}
JsonObject& JsonObject::operator=(const JsonObject& other) {
  if (this != &other) *members_ = *other.members_;
  return *this;
}
JsonObject& JsonObject::operator=(JsonObject&& other) noexcept {
  std::swap(members_, other.members_);
  return *this;
}

JsonObject& JsonObject::add(std::string_view key, double value) {
  // A whole number prints as one ("steps": 150, not 150.0, as the summaries always have);
  // every other double prints as nlohmann's shortest text that reads back as the same double.
  constexpr double kExactIntegers = 9007199254740992.0;  // 2^53
  if (std::trunc(value) == value && std::abs(value) < kExactIntegers && !(value == 0.0 && std::signbit(value)))
    members_->value[std::string(key)] = static_cast<long long>(value);
  else
    members_->value[std::string(key)] = value;
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, long long value) {
  members_->value[std::string(key)] = value;
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, bool value) {
  members_->value[std::string(key)] = value;
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, std::string_view value) {
  members_->value[std::string(key)] = std::string(value);
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, const JsonObject& value) {
  members_->value[std::string(key)] = value.members_->value;
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, const std::vector<JsonObject>& values) {
  Json array = Json::array();
  for (const JsonObject& v : values) array.push_back(v.members_->value);
  members_->value[std::string(key)] = std::move(array);
  return *this;
}

std::string JsonObject::str() const {
  std::string out;
  write(members_->value, out);
  return out;
}

}  // namespace pointfair::cli
