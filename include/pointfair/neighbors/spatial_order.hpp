#pragma once
// A spatially coherent order of a cloud (Morton / Z-order of the quantised positions), and
// the relabelling of neighbourhoods under a permutation. The flow runs on a cloud stored in
// this order so that a point's neighbours sit near it in memory; since every point's result
// depends only on the positions of its neighbours in list order, relabelling changes no bit
// of the result.
#include <cstdint>
#include <span>
#include <vector>

#include "pointfair/neighbors/neighborhoods.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

/// The quantisation of a cloud's Morton codes: 2^21 - 1 quanta over the largest extent of
/// its bounding box, from its low corner.
struct MortonGrid {
  Vec3 low = Vec3::Zero();
  double scale = 0.0;  ///< quanta per unit length; 0 for a cloud of one position
};

/// The Morton grid of a cloud's bounding box (low and high corners).
MortonGrid morton_grid(const Vec3& low, const Vec3& high);
MortonGrid morton_grid(std::span<const Vec3> points);

/// The Morton code of p on `grid`: its quantised coordinates' bits interleaved (x lowest),
/// clamped to the grid; a non-finite coordinate goes to 0.
std::uint64_t morton_code(const MortonGrid& grid, const Vec3& p);

/// order[s] = the index of the point stored at position s: points sorted by the Morton code
/// of their position quantised to 21 bits per axis over the bounding box, ties by index.
std::vector<Index> spatial_order(std::span<const Vec3> points);
/// The same on a given grid (a whole cloud's, for some of its points).
std::vector<Index> spatial_order(std::span<const Vec3> points, const MortonGrid& grid);

/// The inverse permutation: inverse[order[s]] = s.
std::vector<Index> inverse_permutation(std::span<const Index> order);

/// Neighbourhoods of the reordered cloud: row s is row order[s] of `nb`, with every index j
/// replaced by inverse[j]. List order (and so the canonical tie rule by original index) is kept.
Neighborhoods permute_neighborhoods(const Neighborhoods& nb, std::span<const Index> order,
                                    std::span<const Index> inverse);

/// The same as nb = permute_neighborhoods(nb, order, inverse), without a second copy.
void permute_neighborhoods_in_place(Neighborhoods& nb, std::span<const Index> order,
                                    std::span<const Index> inverse);

/// Neighbourhoods of `points` (built as build_neighborhoods would, canonical in the points'
/// own indices) for the reordered cloud: row s belongs to point order[s], and every index j is
/// replaced by row_of[j]. Needs no second copy of the lists.
Neighborhoods build_reordered_neighborhoods(std::span<const Vec3> points, const NeighborParams& params,
                                            std::span<const Index> order,
                                            std::span<const Index> row_of);

/// Every index j in the lists replaced by row_of[j] (rows and list order kept): lists of a
/// cloud's points as the lists of its reordered copy.
void relabel_neighborhoods_in_place(Neighborhoods& nb, std::span<const Index> row_of);

/// Reorders `values` in place so that values[s] becomes the old values[order[s]] (one bit
/// of scratch per point). `inverse` undoes it.
void permute_in_place(std::vector<Vec3>& values, std::span<const Index> order);

/// out[s] = in[order[s]].
std::vector<Vec3> gather(std::span<const Vec3> in, std::span<const Index> order);
/// out[order[s]] = in[s].
std::vector<Vec3> scatter(std::span<const Vec3> in, std::span<const Index> order);

}  // namespace pointfair
