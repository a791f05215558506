// Every point moved by the coarse points' moves out of core (coarse_stages.hpp): each tile
// gathers the coarse points around it, in a halo grown until every point's nearest coarse
// points are certain, as add_coarse_moves needs them.
#include <cmath>
#include <limits>

#include "coarse_stages.hpp"
#include "pointfair/flow/coarse_moves.hpp"

namespace pointfair::tiles::coarse {

void write_moved_points(const fs::path& input, const fs::path& sample, const fs::path& coarse_run,
                        const fs::path& output, const MortonGrid& grid, int k, double first_halo,
                        std::uint64_t budget, const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
  const h5::File in = h5::File::open(input, false);
  const TileTable tiles = read_tile_table(in);
  const std::uint64_t n = point_count(in);
  const h5::File coarse = h5::File::open(sample, false);
  const TileTable coarse_tiles = read_tile_table(coarse);
  const h5::File run = h5::File::open(coarse_run, false);
  if (!has_finished_run(run)) run.fail(layout::run, "the coarse level's run is not finished");
  if (point_count(run) != point_count(coarse)) run.fail(layout::positions, "is not the run of " + sample.string());
  // The coarse points where the coarse run started and where it ended, and its normals there.
  const Column columns[] = {{&coarse, layout::positions},
                            {&run, run.string_attribute(layout::run, "result_positions")},
                            {&run, std::string(layout::run_attributes) + "/normal"}};
  h5::File out = create_container(output, n, tiles, input.filename().string());
  h5::Dataset out_positions = out.dataset(layout::positions), out_index = out.dataset(layout::original_index);
  const h5::Dataset in_positions = in.dataset(layout::positions), in_index = in.dataset(layout::original_index);
  std::vector<Box> bounds = tiles.bounds;  // the moved points' (an empty tile's stay)
  std::vector<Vec3> points, result;
  std::vector<std::uint64_t> index;
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    const std::uint64_t rows = tiles.rows(t);
    if (rows == 0) continue;
    points.resize(rows);
    in_positions.read_rows(tiles.offsets[t], rows, points.data()->data());
    for (double halo = first_halo;; halo *= 2.0) {
      Gathered g = gather_around(coarse, coarse_tiles, tiles.bounds[t], halo, coarse_tiles.size(), columns);
      // The tile twice, its search order and reach; the gathered points, their copy while
      // sorted, the moved ones, and their tree (a sorted copy, its order and nodes).
      require_budget(rows * 64 + 2 * g.bytes() + g.original.size() * 64, budget, input);
      std::vector<Vec3>& anchors = g.columns[0];
      std::vector<Vec3>& moved = g.columns[1];
      const std::vector<Vec3>& normals = g.columns[2];
      // Only the coarse points' moves across the surface (along their normals) carry over,
      // as in core (smooth.cpp).
      for (std::size_t j = 0; j < anchors.size(); ++j) {
        const Vec3& nj = normals[j];
        if (nj.allFinite() && nj.squaredNorm() > 0.5) moved[j] = anchors[j] + (moved[j] - anchors[j]).dot(nj) * nj;
      }
      result = points;
      const double reach2 = add_coarse_moves(result, anchors, moved, k, grid);
      if (holds_all(coarse_tiles, tiles.bounds[t], halo) || std::sqrt(reach2) < halo * (1.0 - 1e-9)) break;
    }
    bounds[t] = bounds_of(result);
    out_positions.write_rows(tiles.offsets[t], rows, result.data()->data());
    index.resize(rows);
    in_index.read_rows(tiles.offsets[t], rows, index.data());
    out_index.write_rows(tiles.offsets[t], rows, index.data());
    if (progress) progress(t + 1, tiles.size());
  }
  write_tile_bounds(out, bounds);
  out.flush();
}

}  // namespace pointfair::tiles::coarse
