// The coarse level's containers and their memory budget (coarse_stages.hpp).
#include "coarse_stages.hpp"
#include "pointfair/common/version.hpp"

namespace pointfair::tiles::coarse {

h5::File create_container(const fs::path& path, std::uint64_t n, const TileTable& tiles, const std::string& source) {
  h5::File f = h5::File::create(path);
  f.set_attribute("/", "pointfair_format", layout::format_name);
  f.set_attribute("/", "format_version", layout::format_version);
  f.set_attribute("/", "tool_version", version());
  f.set_attribute("/", "source_name", source);
  f.set_attribute("/", "source_size_bytes", std::int64_t{0});
  f.set_attribute("/", "point_count", static_cast<std::int64_t>(n));
  f.set_attribute("/", "tile_count", static_cast<std::int64_t>(tiles.size()));
  h5::DatasetOptions rows;
  rows.allocate_early = true;
  rows.chunk_rows = std::min<std::uint64_t>(65536, std::max<std::uint64_t>(n, 1));
  f.create_group(layout::points);
  f.create_dataset(layout::positions, h5::Type::Float64, n, 3, rows);
  f.set_attribute(layout::positions, "source_type", "float64");
  f.create_dataset(layout::original_index, h5::Type::UInt64, n, 0, rows);
  f.create_group(layout::attributes);
  f.create_group(layout::tiles);
  f.create_dataset(layout::tile_offsets, h5::Type::UInt64, tiles.offsets.size(), 0)
      .write_rows(0, tiles.offsets.size(), tiles.offsets.data());
  f.create_dataset(layout::tile_bounds, h5::Type::Float64, tiles.size(), 6);
  return f;
}

void write_tile_bounds(h5::File& file, const std::vector<Box>& bounds) {
  if (!bounds.empty()) file.dataset(layout::tile_bounds).write_rows(0, bounds.size(), bounds.data()->data());
}

void require_budget(std::uint64_t needed, std::uint64_t budget, const fs::path& input) {
  if (needed <= budget) return;
  throw BudgetError("the memory budget of " + size_text(budget, false) + " is too small for the coarse level of " +
                        input.string() + " (it needs " + size_text(needed, true) +
                        "): give a larger budget, or import the input again with a smaller budget (smaller tiles)",
                    budget, needed);
}

}  // namespace pointfair::tiles::coarse
