// A number as the help texts and progress lines write it.
#pragma once

#include <string>

namespace pointfair::cli {

/// A number as printf's %g writes it (as the help texts state defaults).
std::string format_number(double value);

}  // namespace pointfair::cli
