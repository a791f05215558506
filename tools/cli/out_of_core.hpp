#pragma once
// Shared pieces of the out-of-core commands (import, export, smooth on containers).
#include <cstdint>
#include <filesystem>
#include <string_view>

#include "pointfair/finish/quadric_projection.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair::cli {

/// True for .h5 / .hdf5 (case-insensitive).
bool is_container_path(const std::filesystem::path& path);

/// Parses a size in bytes: "1048576", "512K", "256M", "256MiB", "2G", "2GiB" (binary units).
std::uint64_t parse_size(std::string_view text, std::string_view what);

/// Size in bytes of the input file `file` (of a folder: of its point files, io::point_files_in).
/// Throws IoError naming it when it is missing or not a regular file (a named pipe, a device:
/// io::require_regular_input).
std::uint64_t input_file_size(const std::filesystem::path& file);

/// Number of points of a point file (of a folder: of its point files together): the PLY
/// header's count, or a pass over a text file.
/// Throws IoError as the file's reader.
std::uint64_t count_points(const std::filesystem::path& file);

/// The least memory budget the streaming import accepts (tiles::import_points).
inline constexpr std::uint64_t kMinImportBudget = std::uint64_t{16} << 20;

/// Bytes an in-core smooth of `points` points with k neighbours needs, roughly; `compensated`:
/// with SmoothParams::shrink_compensation (one more buffer of positions).
std::uint64_t in_core_bytes(std::uint64_t points, int k, bool compensated = false);
/// What the in-core quadric finish adds to that.
std::uint64_t in_core_finish_bytes(std::uint64_t points, const QuadricProjectionParams& finish);

/// Whether `pointfair smooth` runs a point file of `points` points in core under a memory
/// budget of `budget` bytes: when in_core_bytes (sized for the largest automatic k, which is
/// not known before the cloud is read) and in_core_finish_bytes fit in it.
bool fits_in_core(std::uint64_t points, const SmoothParams& params, std::uint64_t budget);

}  // namespace pointfair::cli
