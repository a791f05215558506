#pragma once
// What differs between a run file's resume key and the key of the run asked for: the words a
// refused --resume names, so that the user sees which parameter to give. A key is a line of
// "name=value" entries separated by spaces (parameter_forms.hpp). Internal: not installed.
#include <string>
#include <string_view>

namespace pointfair::tiles::detail {

/// The entries of `stored` (the run file's key) and `current` (this run's) that differ, as
/// "name: V in the run, W now" (or "not in the run" / "not set now"; reals in their shortest
/// form that reads back the same: 0.8, not 0.80000000000000004), joined by "; ", in the
/// stored key's order and then the current key's new names; empty when the keys name the same
/// entries with the same values.
std::string key_differences(std::string_view stored, std::string_view current);

}  // namespace pointfair::tiles::detail
