#pragma once
// Whether a smooth runs in core or out of core: a rough estimate of the memory an in-core run
// takes, and the rule the command line, the Python module and the benchmarks share.
#include <cstdint>
#include <filesystem>
#include <optional>

#include "pointfair/finish/quadric_projection.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair::tiles {

/// Bytes an in-core smooth of `points` points with k neighbours needs, roughly; `compensated`:
/// with SmoothParams::shrink_compensation (one more buffer of positions).
std::uint64_t in_core_bytes(std::uint64_t points, int k, bool compensated = false);

/// What the in-core quadric finish `finish` adds to in_core_bytes for `points` points.
std::uint64_t in_core_finish_bytes(std::uint64_t points, const QuadricProjectionParams& finish);

/// Whether an in-core smooth of `points` points with `params` fits in `budget` bytes: when
/// in_core_bytes (sized for flow_k_bound, the largest automatic k, which is not known before
/// the cloud is read) and in_core_finish_bytes fit in it.
bool fits_in_core(std::uint64_t points, const SmoothParams& params, std::uint64_t budget);

/// Whether a smooth of `input` into `output` runs out of core: a container (is_container_path)
/// input or output, a resume, or a point file whose in-core run does not fit `memory_budget`
/// (fits_in_core); without a budget, only containers and a resume. A point-file input is
/// counted (io::count_points: the header's count or a counting pass over a text file) whenever
/// a budget, a container output or a resume is given: throws IoError as its reader.
bool runs_out_of_core(const std::filesystem::path& input, const std::filesystem::path& output,
                      const SmoothParams& params, std::optional<std::uint64_t> memory_budget, bool resume = false);

}  // namespace pointfair::tiles
