#pragma once
// How the run file writes a parameter table's entry (common/parameter.hpp): in the resume key
// ("name=value": integers, flags as 0 or 1, choices as their enum's code, reals to 17 digits)
// and as an attribute (integers and flags as int64, reals as double, choices by their stored
// name).
#include <ostream>
#include <string_view>

#include "pointfair/common/parameter.hpp"
#include "pointfair/tiles/hdf5_file.hpp"

namespace pointfair::tiles::detail {

/// Writes "name=value" to `s` (whose precision the caller sets); `by_name`: a choice by its
/// stored name rather than its code.
inline void write_key(std::ostream& s, std::string_view name, const ParameterValue& v, bool by_name = false) {
  s << name << '=';
  if (v.kind == ParameterValue::Kind::Real) s << v.real;
  else if (v.kind == ParameterValue::Kind::Choice && by_name) s << v.stored;
  else s << v.integer;
}

/// Sets the attribute `name` of `object` in `file` to `v`.
inline void store_parameter(h5::File& file, std::string_view object, std::string_view name, const ParameterValue& v) {
  switch (v.kind) {
    case ParameterValue::Kind::Integer:
    case ParameterValue::Kind::Flag: file.set_attribute(object, name, v.integer); return;
    case ParameterValue::Kind::Real: file.set_attribute(object, name, v.real); return;
    case ParameterValue::Kind::Choice: file.set_attribute(object, name, v.stored); return;
  }
}

}  // namespace pointfair::tiles::detail
