#pragma once
namespace pointfair {
/// The library's version, "major.minor.patch".
const char* version();
}  // namespace pointfair
