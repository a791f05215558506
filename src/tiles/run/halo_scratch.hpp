#pragma once
// The halos of a streamed step, laid out tile by tile in a scratch file beside the run file.
//
// A step that streams its tiles reads each tile's halo: rows of the neighbouring tiles,
// scattered over them. Read from the run file, that is one HDF5 selection of many short runs
// (thousands of small reads a step, and spans read whole around them: on a 1M-point cube in
// 32 tiles, 215 MB read a step where the rows needed are 96 MB). Here each tile's writer also
// writes the rows of it that other tiles' halos name, into each such tile's own contiguous
// range of the scratch file: the next step reads a tile's halo with one read.
//
// Two buffers, like the run file's positions: the step writes buffer b while it reads the
// other. The file is unlinked as soon as it is open (it leaves nothing behind when the run
// ends or is killed) and its content is never needed to resume: a run that starts, or whose
// halos changed (a rebuild), reads its first step's halos from the run file. Not HDF5, so its
// calls need not stay on the HDF5 thread; the step calls it from there all the same.
// Internal: not installed.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "pointfair/types.hpp"
#include "scratch_file.hpp"

namespace pointfair::tiles {

class HaloScratch {
 public:
  /// `halo_rows[t]`: tile t's halo rows (ascending container rows, none of its own), for
  /// the tiles [first_tile, end_tile) whose rows `offsets` (the tile table's) delimit; the
  /// halos may only name rows of those tiles. `order_of(u)`: the order in which tile u's
  /// points are given to write() (entry s: the row offset in the tile of point s; empty: row
  /// order), called once per tile here. The scratch file goes into `directory`; `name` is
  /// what errors call it. Throws io::IoError when it cannot be created.
  using OrderOf = std::function<std::vector<Index>(std::size_t tile)>;
  HaloScratch(const std::filesystem::path& directory, std::string name,
              std::span<const std::vector<std::uint64_t>> halo_rows, std::span<const std::uint64_t> offsets,
              std::size_t first_tile, std::size_t end_tile, const OrderOf& order_of = {});
  HaloScratch(const HaloScratch&) = delete;
  HaloScratch& operator=(const HaloScratch&) = delete;

  /// Tile t's halo in buffer b (0 or 1), into `out` (its halo_rows.size() points, in their order).
  void read(int b, std::size_t t, Vec3* out) const;
  /// From tile u's positions (`points`, one per row of the tile, in the order order_of gave),
  /// the points of it that the halos name, into buffer b. Uses a staging buffer: one caller
  /// at a time.
  void write(int b, std::size_t u, const Vec3* points);
  /// Bytes held in memory (the tables and the staging buffer at its largest).
  std::uint64_t bytes() const;
  /// Bytes of one buffer in the file.
  std::uint64_t buffer_bytes() const { return total_ * sizeof(Vec3); }

 private:
  // Points [first, first + count) of picks_ go to rows [at, at + count) of a buffer.
  struct Run {
    std::uint64_t at = 0;
    std::uint64_t first = 0, count = 0;
  };
  static constexpr std::uint64_t kStagingPoints = 1024;

  ScratchFile file_;
  std::size_t first_tile_ = 0;
  std::uint64_t total_ = 0;                 // halo rows of every tile: rows of one buffer
  std::vector<std::uint64_t> halo_begin_;   // tile t's halo: rows [halo_begin_[t], halo_begin_[t + 1])
  std::vector<std::uint64_t> runs_begin_;   // tile u's runs: runs_[runs_begin_[u] .. runs_begin_[u + 1])
  std::vector<Run> runs_;
  std::vector<Index> picks_;                // a run's points: indices into write()'s `points`
  std::vector<Vec3> staging_;
};

}  // namespace pointfair::tiles
