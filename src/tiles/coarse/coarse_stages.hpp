#pragma once
// The coarse level out of core (SmoothParams::coarse): smooth()'s run_coarse_level tile by tile,
// the same bits. Its parts, in the order a run goes through them:
//   tile_gather.cpp    a container's rows in and around a box, sorted by original index
//   coarse_files.cpp   the stages' containers, and their memory budget
//   sample_tiles.cpp   the coarse sample, written as a container of its own (same tiles)
//   move_tiles.cpp     every point moved by the coarse points' moves: the fine run's start
//   coarse_level.cpp   the stages and the runs in order, in a work folder beside the output
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "pointfair/neighbors/coarse_sample.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"
#include "pointfair/types.hpp"

namespace pointfair::tiles::coarse {

namespace fs = std::filesystem;

// One column of Vec3 rows of a container (or of a run on it): the same rows as its positions.
struct Column {
  const h5::File* file = nullptr;
  std::string path;
};

// Rows of a container gathered around a box: each column's values, the original indices, and
// where the rows of the tile the box belongs to went. Sorted by original index (the tie rule
// of the canonical order, as in core).
struct Gathered {
  std::vector<std::vector<Vec3>> columns;
  std::vector<std::uint64_t> original;
  std::vector<std::int64_t> tile_row;  // the row within `own`, or -1
  std::uint64_t bytes() const;
};

// Every row whose first column lies in `box` grown by `halo` on every side, and every row of
// tile `own` (tiles.size() for none), from the tiles that meet the grown box. IoError for a
// non-finite coordinate.
Gathered gather_around(const h5::File& file, const TileTable& tiles, const Box& box, double halo,
                       std::size_t own, std::span<const Column> columns);

// True when `box` grown by `halo` holds every point of `tiles` (their bounds).
bool holds_all(const TileTable& tiles, const Box& box, double halo);

// A container at `path` (created, truncating) with n points and tile table `tiles` (its
// offsets; bounds written by write_tile_bounds): positions and original indices, the
// attributes of an import. Datasets allocated at creation.
h5::File create_container(const fs::path& path, std::uint64_t n, const TileTable& tiles, const std::string& source);
void write_tile_bounds(h5::File& file, const std::vector<Box>& bounds);

// The memory the stages may use: throws BudgetError naming `input` when `needed` bytes exceed it.
void require_budget(std::uint64_t needed, std::uint64_t budget, const fs::path& input);

// Writes the coarse sample of container `input` (coarse_sample with `cells`, `ratio` over
// the whole cloud) to the container `output`: the sampled points of each input tile in that
// tile, ascending in original index, their original index their rank among the sampled
// points (the coarse cloud's order in core). Returns the sample's size.
std::uint64_t write_coarse_sample(const fs::path& input, const fs::path& output, const CoarseCells& cells, int ratio,
                                  std::uint64_t budget, const std::function<void(std::uint64_t, std::uint64_t)>& progress);

// Writes the start of the fine run to the container `output` (the input's tiles, rows and
// original indices): every input point moved by add_coarse_moves over the coarse points
// (`sample`'s positions, moved across the surface as far as the coarse run `coarse_run`
// moved them along its normals).
void write_moved_points(const fs::path& input, const fs::path& sample, const fs::path& coarse_run,
                        const fs::path& output, const MortonGrid& grid, int k, double first_halo,
                        std::uint64_t budget, const std::function<void(std::uint64_t, std::uint64_t)>& progress);

// smooth_out_of_core with SmoothParams::coarse (coarse_level.cpp). `nested`: the coarse level
// of a coarse level, which runs whatever the noise, as in core.
OutOfCoreReport smooth_with_coarse_level(const fs::path& input, const fs::path& output, const SmoothParams& params,
                                         const OutOfCoreOptions& options, bool nested);

}  // namespace pointfair::tiles::coarse
