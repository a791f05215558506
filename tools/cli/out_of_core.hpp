#pragma once
// Shared pieces of the out-of-core commands' argument handling (import, export, smooth on
// containers). What decides and sizes a run is the library's (pointfair/tiles/budget.hpp,
// pointfair/tiles/out_of_core_decision.hpp).
#include <cstdint>
#include <filesystem>
#include <string_view>

namespace pointfair::cli {

/// Parses a size in bytes: "1048576", "512K", "256M", "256MiB", "2G", "2GiB" (binary units).
std::uint64_t parse_size(std::string_view text, std::string_view what);

/// Size in bytes of the input file `file` (of a folder: of its point files, io::point_files_in).
/// Throws IoError naming it when it is missing or not a regular file (a named pipe, a device:
/// io::require_regular_input).
std::uint64_t input_file_size(const std::filesystem::path& file);

}  // namespace pointfair::cli
