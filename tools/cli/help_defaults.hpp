#pragma once
// The defaults the help text gives, read from the parameter tables (smooth_parameters.hpp,
// finish/quadric_parameters.hpp) that also write the --json summary, the run file's
// attributes and the resume key: an option's help cannot name a default the library does not
// have.
#include <string>
#include <string_view>

#include "pointfair/finish/quadric_parameters.hpp"
#include "pointfair/smooth_parameters.hpp"

namespace pointfair::cli {

/// "Default X", X the value of the smoothing parameter named `key` in the resume key (a
/// number as the help prints it, on/off, a choice's command-line name) in SmoothParams{}.
std::string smooth_default(std::string_view key);

/// The same for the quadric finish's parameter `key`, in QuadricProjectionParams{}.
std::string finish_default(std::string_view key);

}  // namespace pointfair::cli
