#pragma once
// One entry of a parameter table: a parameter's names in the forms that print or store it
// (the resume key of an out-of-core run, the --json summary, the run file's attributes) and
// its value as those forms see it. The tables themselves sit beside their parameter structs
// (finish/quadric_parameters.hpp, smooth_parameters.hpp).
#include <cstdint>
#include <span>
#include <string_view>

namespace pointfair {

/// A parameter's value: an integer, a real number, a flag or one of an enum's choices.
struct ParameterValue {
  enum class Kind { Integer, Real, Flag, Choice };
  Kind kind = Kind::Real;
  /// Integer; Flag (0 or 1); Choice: the enum's code (the resume key writes it).
  std::int64_t integer = 0;
  /// Real.
  double real = 0.0;
  /// Choice: the command line's name (name_of) and the run file's (stored_name_of).
  std::string_view name = {}, stored = {};
};

constexpr ParameterValue integer_value(std::int64_t v) { return {.kind = ParameterValue::Kind::Integer, .integer = v}; }
constexpr ParameterValue real_value(double v) { return {.kind = ParameterValue::Kind::Real, .real = v}; }
constexpr ParameterValue flag_value(bool v) { return {.kind = ParameterValue::Kind::Flag, .integer = v ? 1 : 0}; }

template <class Params>
struct Parameter {
  /// Its name in the resume key ("name=value"); empty: not in the key.
  std::string_view key;
  /// Its name in the --json summary's block; empty: not in it.
  std::string_view json;
  /// The run file's attribute; empty: not stored.
  std::string_view stored;
  /// Its value in `params`.
  ParameterValue (*value)(const Params& params);
  /// Named in the resume key only when this holds (nullptr: always), so that runs started
  /// before the parameter existed still resume.
  bool (*key_when)(const Params& params) = nullptr;
  /// A choice the resume key names (rather than giving its enum's code).
  bool key_by_name = false;
};

/// The entry of `table` whose name in a form (`form`: &Parameter::json, ::stored or ::key) is
/// `name`; nullptr if none.
template <class Params>
constexpr const Parameter<Params>* find_parameter(std::span<const Parameter<Params>> table,
                                                  std::string_view Parameter<Params>::*form, std::string_view name) {
  for (const Parameter<Params>& p : table)
    if (p.*form == name) return &p;
  return nullptr;
}

/// Whether `order` names each entry of `table` that has a name in `form` exactly once: a form
/// written in an order of its own still covers the table. `order` may name more (what the form
/// writes besides the table's values, such as a resolved k).
template <class Params>
constexpr bool covers(std::span<const Parameter<Params>> table, std::string_view Parameter<Params>::*form,
                      std::span<const std::string_view> order) {
  for (const Parameter<Params>& p : table) {
    if ((p.*form).empty()) continue;
    std::size_t seen = 0;
    for (const std::string_view name : order) seen += name == p.*form ? 1 : 0;
    if (seen != 1) return false;
  }
  return true;
}

/// Whether every name of `order` is the name in `form` of an entry of `table`.
template <class Params>
constexpr bool names_only_entries(std::span<const Parameter<Params>> table, std::string_view Parameter<Params>::*form,
                                  std::span<const std::string_view> order) {
  // Names compared, not find_parameter's pointer to nullptr: with -fsanitize=undefined, gcc
  // does not take that comparison as a constant expression in a static_assert.
  for (const std::string_view name : order) {
    bool found = false;
    for (const Parameter<Params>& p : table) found = found || p.*form == name;
    if (!found) return false;
  }
  return true;
}

/// A choice's value: its enum's code and its names (smooth_names.hpp).
template <class Enum>
constexpr ParameterValue choice_value(Enum v, std::string_view name, std::string_view stored) {
  return {.kind = ParameterValue::Kind::Choice, .integer = static_cast<std::int64_t>(v), .name = name, .stored = stored};
}

}  // namespace pointfair
