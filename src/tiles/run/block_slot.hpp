#pragma once
// One tile in flight of a temporal block (or of a block of one step) of the out-of-core run:
// the tile with the rings of its neighbour-list closure, and the h steps computed on them.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "pointfair/flow/euler_step.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"
#include "row_map.hpp"
#include "scratch_file.hpp"
#include "tile_moves.hpp"
#include "vector_bytes.hpp"

namespace pointfair::tiles::detail {

// One tile in flight of a temporal block of h steps: its points (levels 0) and the rings of
// its neighbour-list closure (level l + 1: the neighbours of levels <= l not already in them),
// d = h levels deep, in local indices ordered by level. Step j of the block moves the points of
// levels 0 .. h - j, each from the positions of step j - 1 of its neighbours (one level
// further out at most), so after h steps the tile's points hold exactly the in-core step.
// A compensated step (SmoothParams::shrink_compensation) needs the plain updates of a point's
// neighbours, which need their own neighbours: two rings a step, d = 2 h levels. Step j then
// takes the plain update of levels 0 .. d - 2 j + 1 and compensates levels 0 .. d - 2 j.
struct BlockSlot {
  std::size_t tile = 0;
  std::vector<std::size_t> level_end;      // end of level l in local indices, l = 0 .. h
  std::vector<Neighborhoods> lists;        // lists of levels 0 .. h - 1, local indices (built)
  // What compute() reads: each level's lists (in `lists`, or in `mapped`), and where they lie
  // one after the other (mapped), all levels as one (stride 0 otherwise).
  std::vector<NeighborhoodsView> views;
  NeighborhoodsView all;
  ScratchFile::Mapping mapped;             // the block-lists scratch's record of the tile
  std::vector<Vec3> cur, next;
  std::vector<Vec3> updated;               // plain updates of a compensated step
  std::vector<Index> ids;                  // 0, 1, 2, ...
  std::vector<std::size_t> degenerate;     // per step of the block, the tile's own points
  std::vector<std::uint64_t> rows;         // container row of each local point
  std::vector<std::uint64_t> sorted_rows;  // ring rows ascending, and their local indices
  std::vector<Index> sorted_local;
  RowMap ring_local;                       // the same, looked up by row
  std::vector<std::uint32_t> global;       // lists of a level in container rows, while reading
  std::vector<std::uint16_t> counts;
  std::vector<Vec3> scratch;
  // The tile's points in Morton order (blocks whose lists come from the block-lists scratch):
  // local point s < the tile's size is its row order[s] (empty: row s); `by_row` holds the
  // tile's positions in row order, read before the block and written after it.
  std::vector<Index> order;
  std::vector<Vec3> by_row;
  // A block whose source holds the tile in that order (written so by the previous block):
  // read straight into `cur`. One that writes it so: `cur` is the result, `by_row` unused.
  bool read_listed = false, write_listed = false;
  // With momentum (blocks of one step): the tile's last moves, in the order of `cur`.
  TileMoves moves;
  // bytes() as the writing thread last measured it, between the slot's compute stages: the
  // compute trades `cur` and `next`, so the slot's vectors are not read while it runs.
  std::uint64_t accounted = 0;

  std::uint64_t bytes() const {
    std::uint64_t b = detail::bytes(level_end) + detail::bytes(cur) + detail::bytes(next) + detail::bytes(updated) +
                      detail::bytes(ids) +
                      detail::bytes(degenerate) + detail::bytes(rows) + detail::bytes(sorted_rows) +
                      detail::bytes(sorted_local) + detail::bytes(global) + detail::bytes(counts) + detail::bytes(scratch) + ring_local.bytes() +
                      detail::bytes(order) + detail::bytes(by_row) + moves.bytes() + mapped.size() + detail::bytes(views);
    for (const Neighborhoods& l : lists) b += detail::bytes(l.indices) + detail::bytes(l.counts);
    return b;
  }
  std::size_t points() const { return level_end.back(); }

  // `beta`: SmoothParams::shrink_compensation (0: plain steps); the block has d = h levels
  // of lists, or 2 h when compensated. A block of one step may have momentum m (from
  // `moves`), and keep its own moves there for the next step (`keep_moves`).
  void compute(const FlowParams& flow, double lambda, double beta, double m = 0.0, bool keep_moves = false);
  // The tile's positions after the block, in row order.
  const Vec3* tile_rows() const { return order.empty() || write_listed ? cur.data() : by_row.data(); }
};

}  // namespace pointfair::tiles::detail
