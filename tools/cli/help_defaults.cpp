#include "help_defaults.hpp"

#include <cassert>
#include <span>

#include "number_text.hpp"

namespace pointfair::cli {
namespace {

std::string value_text(const ParameterValue& v) {
  switch (v.kind) {
    case ParameterValue::Kind::Integer: return std::to_string(v.integer);
    case ParameterValue::Kind::Real: return format_number(v.real);
    case ParameterValue::Kind::Flag: return v.integer != 0 ? "on" : "off";
    case ParameterValue::Kind::Choice: return std::string(v.name);
  }
  return {};
}

template <class Params>
std::string default_of(std::span<const Parameter<Params>> table, std::string_view key) {
  const Parameter<Params>* p = find_parameter(table, &Parameter<Params>::key, key);
  assert(p != nullptr && "the help names a parameter of the table");
  return "Default " + value_text(p->value(Params{}));
}

}  // namespace

std::string smooth_default(std::string_view key) {
  return default_of(std::span<const SmoothParameter>(kSmoothParameters), key);
}

std::string finish_default(std::string_view key) {
  return default_of(std::span<const QuadricParameter>(kQuadricParameters), key);
}

}  // namespace pointfair::cli
