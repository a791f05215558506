#include "pointfair/tiles/tiled_smooth.hpp"

#include <string>

#include "coarse/coarse_stages.hpp"
#include "run/run.hpp"

namespace pointfair::tiles {

namespace fs = std::filesystem;

std::string size_text(std::uint64_t bytes, bool up) {
  const std::uint64_t unit = bytes < (std::uint64_t{1} << 20) ? 10 : 20;
  const std::uint64_t n = (bytes >> unit) + (up && (bytes & ((std::uint64_t{1} << unit) - 1)) != 0 ? 1 : 0);
  return std::to_string(n) + (unit == 10 ? " KiB" : " MiB");
}

fs::path partial_name(const fs::path& output) {
  fs::path p = output;
  p += ".partial";
  return p;
}

OutOfCoreReport smooth_out_of_core(const fs::path& input, const fs::path& output, const SmoothParams& params,
                                   const OutOfCoreOptions& options) {
  // As in core, neighbourhoods from a reference cloud leave out the coarse level.
  if (params.coarse && options.neighbor_reference.empty())
    return coarse::smooth_with_coarse_level(input, output, params, options, false);
  SmoothParams without = params;
  without.coarse.reset();
  return detail::Run(input, output, without, options).run();
}

}  // namespace pointfair::tiles
