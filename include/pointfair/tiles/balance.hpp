#pragma once
// Work of a distributed run: contiguous ranges of the tile order, one per rank, of about
// equal cost (a tile's cost: its points plus its halo, the rows one step reads).
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace pointfair::tiles {

/// Splits tiles 0..costs.size()-1 into `parts` contiguous ranges: returns parts + 1
/// ascending boundaries b (b[0] = 0, b[parts] = costs.size()); part p holds tiles
/// [b[p], b[p + 1]). Boundary p is where the prefix cost comes nearest to p / parts of the
/// total, so no part exceeds its share by more than one tile's cost. Parts may be empty
/// (fewer tiles than parts). Throws ParamError when parts < 1.
std::vector<std::size_t> balance_ranges(std::span<const std::uint64_t> costs, int parts);

}  // namespace pointfair::tiles
