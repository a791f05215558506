// The coarse sample out of core (coarse_stages.hpp): each tile with the cells around it draws
// the whole cloud's sample of its own points (coarse_sample.hpp), twice: once to count and
// mark them (their ranks among the sampled points are their original indices in the coarse
// cloud), once to write them.
#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "coarse_stages.hpp"

namespace pointfair::tiles::coarse {

namespace {

// The sampled points of tile t, ascending in original index: their places in `g`.
std::vector<std::size_t> tile_sample(const Gathered& g, const CoarseCells& cells, int ratio) {
  std::vector<std::size_t> mine;
  for (const Index i : coarse_sample(g.columns[0], cells, ratio))
    if (g.tile_row[i] >= 0) mine.push_back(i);
  return mine;
}

}  // namespace

std::uint64_t write_coarse_sample(const fs::path& input, const fs::path& output, const CoarseCells& cells, int ratio,
                                  std::uint64_t budget, const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
  const h5::File in = h5::File::open(input, false);
  const TileTable tiles = read_tile_table(in);
  const std::uint64_t n = point_count(in);
  // A cell's points lie within one cell edge (and the rounding of the grid's quanta) of each
  // other: a halo of that around the tile holds every cell its points are in.
  const double edge = cells.edge();
  const double halo = std::isfinite(edge) ? edge * (1.0 + 1e-9) + 2.0 / cells.grid.scale
                                          : std::numeric_limits<double>::infinity();
  const Column positions[] = {{&in, layout::positions}};
  // Which original indices are sampled, and how many before each word of 64.
  std::vector<std::uint64_t> sampled((n + 63) / 64, 0);
  std::vector<std::uint64_t> counts(tiles.size(), 0);
  const std::uint64_t persistent = sampled.size() * 2 * sizeof(std::uint64_t) + tiles.size() * sizeof(Box);
  const auto gather = [&](std::size_t t) {
    Gathered g = gather_around(in, tiles, tiles.bounds[t], halo, t, positions);
    // The gathered rows, their copy while sorted, and the sample's Morton codes and order.
    require_budget(persistent + 2 * g.bytes() + g.original.size() * 24, budget, input);
    return g;
  };
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    if (tiles.rows(t) == 0) continue;
    const Gathered g = gather(t);
    for (const std::size_t i : tile_sample(g, cells, ratio)) {
      sampled[g.original[i] / 64] |= std::uint64_t{1} << (g.original[i] % 64);
      ++counts[t];
    }
    if (progress) progress(t + 1, 2 * tiles.size());
  }
  std::vector<std::uint64_t> before(sampled.size() + 1, 0);
  for (std::size_t w = 0; w < sampled.size(); ++w) before[w + 1] = before[w] + std::popcount(sampled[w]);
  const std::uint64_t m = before.back();
  // The input's tiles (pairs of them, as many points as an input tile, left the coarse run's
  // plan of a 4 MiB budget short by 9 KB on a 12K-point sphere).
  const std::size_t coarse_tiles = tiles.size();
  TileTable coarse;
  coarse.offsets.assign(coarse_tiles + 1, 0);
  for (std::size_t t = 0; t < coarse_tiles; ++t) coarse.offsets[t + 1] = coarse.offsets[t] + counts[t];
  constexpr double inf = std::numeric_limits<double>::infinity();
  coarse.bounds.assign(coarse_tiles, Box{inf, inf, inf, -inf, -inf, -inf});
  h5::File out = create_container(output, m, coarse, input.filename().string());
  h5::Dataset out_positions = out.dataset(layout::positions), out_index = out.dataset(layout::original_index);
  std::vector<Vec3> rows;
  std::vector<std::uint64_t> ranks;
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    if (counts[t] == 0) continue;
    const Gathered g = gather(t);
    rows.clear();
    ranks.clear();
    for (const std::size_t i : tile_sample(g, cells, ratio)) {
      const std::uint64_t o = g.original[i];
      const std::uint64_t below = sampled[o / 64] & ((std::uint64_t{1} << (o % 64)) - 1);
      ranks.push_back(before[o / 64] + static_cast<std::uint64_t>(std::popcount(below)));
      rows.push_back(g.columns[0][i]);
    }
    if (rows.size() != counts[t])
      in.fail(layout::positions, "the coarse sample of tile " + std::to_string(t) + " changed between two reads");
    coarse.bounds[t] = bounds_of(rows);
    out_positions.write_rows(coarse.offsets[t], rows.size(), rows.data()->data());
    out_index.write_rows(coarse.offsets[t], ranks.size(), ranks.data());
    if (progress) progress(tiles.size() + t + 1, 2 * tiles.size());
  }
  write_tile_bounds(out, coarse.bounds);
  out.flush();
  return m;
}

}  // namespace pointfair::tiles::coarse
