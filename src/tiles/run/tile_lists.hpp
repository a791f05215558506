#pragma once
// The neighbour lists of the out-of-core run's tiles: a tile's gathered points with their
// halo, the quadric finish's lists of them, and a tile's lists in local indices.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"
#include "pointfair/tiles/tiling.hpp"
#include "vector_bytes.hpp"

namespace pointfair::tiles::detail {

// A tile's points plus its halo, sorted by original index (for neighbourhood building).
struct LocalSet {
  std::vector<Vec3> positions;
  std::vector<std::uint64_t> rows;      // container rows
  std::vector<std::uint64_t> original;  // original indices
  std::vector<Index> queries;           // local indices of the tile's own points, in row order
  std::uint64_t bytes() const {
    return detail::bytes(positions) + detail::bytes(rows) + detail::bytes(original) + detail::bytes(queries);
  }
};

// A part of one tile that the quadric finish gathers on its own when the whole tile's halo
// would not fit the budget: the tile's rows `rows` (ascending, counted from the tile's first;
// empty: every row), all inside `box`.
struct TilePart {
  Box box;
  std::vector<std::uint64_t> rows;
};

// The quadric finish's lists of one tile's gathered points (LocalSet, local indices): each
// tile point's fit (its k nearest, with fit sharing its share_candidates nearest; row r: the
// tile's row r), with fit sharing each seed's fit that a tile point may share (the tile's
// seeds and the halo's among the tile points' nearest; row r: point seed_queries[r]), and the
// rows every normal those rows read is fitted to (a row for every gathered point, empty for
// those no row reads).
struct FinishLists {
  Neighborhoods fits;
  Neighborhoods seed_fits;
  std::vector<Index> seed_queries;
  Neighborhoods normals;
  std::uint64_t near_bytes = 0;  // what built the halo points' rows held
  std::uint64_t bytes() const {
    return detail::bytes(fits.indices) + detail::bytes(fits.counts) + detail::bytes(seed_fits.indices) +
           detail::bytes(seed_fits.counts) + detail::bytes(seed_queries) + detail::bytes(normals.indices) +
           detail::bytes(normals.counts) + near_bytes;
  }
};

// The rows of a part's points that fit their own (Run::own_fit_rows): row r of `fits` the
// k nearest of the r-th query, and row r of `normals` the nearest of gathered point named[r],
// which no earlier row had named.
struct OwnFitRows {
  Neighborhoods fits;
  std::vector<Index> named;
  Neighborhoods normals;
};

// The neighbour lists of one tile in local indices: local index s < tile size is row
// tile_begin + order[s] (order empty: s itself), else halo_rows[s - tile size]. The order is
// the Morton order of the tile's points (spatial_order.hpp), as the in-core steps use: a
// point's neighbours sit near it in memory, which the input's order inside a tile (the
// import keeps it) does not give. Each list keeps its order, so no bit of a result changes.
struct TileNeighbors {
  Neighborhoods local;
  std::vector<std::uint64_t> halo_rows;
  std::vector<Index> order;
  std::uint64_t bytes() const {
    return detail::bytes(local.indices) + detail::bytes(local.counts) + detail::bytes(halo_rows) + detail::bytes(order);
  }
  // values[order[s]] = local[s] for the tile's rows (row order from local order).
  template <class T, class U>
  void to_rows(const std::vector<T>& local_values, std::vector<U>& values, std::size_t rows) const {
    if (values.size() < rows) values.resize(rows);
    parallel_for(rows, [&](std::size_t begin, std::size_t end) {
      for (std::size_t s = begin; s < end; ++s) values[order.empty() ? s : order[s]] = static_cast<U>(local_values[s]);
    }, 8192);
  }
  // positions[s] = by_row[order[s]] for the tile's rows (local order from row order).
  void to_local(const std::vector<Vec3>& by_row, std::vector<Vec3>& positions, std::size_t rows) const {
    parallel_for(rows, [&](std::size_t begin, std::size_t end) {
      for (std::size_t s = begin; s < end; ++s) positions[s] = by_row[order[s]];
    }, 8192);
  }
};

}  // namespace pointfair::tiles::detail
