#pragma once
// The sort behind the cell-grid k-nearest search (knn_grid.hpp): a few candidates, each a
// squared distance and a point index, into the canonical order of the neighbour lists
// (squared distance, ties by the smaller index).
//
// Each candidate's place is the number of candidates strictly closer, counted in vectorised
// passes without a data-dependent branch (the sorted insertion it replaces mispredicted about
// once per candidate); candidates tied at one distance take the next free places and each run
// of ties is then ordered by index. Only comparisons: the same order bit for bit on either
// kernel. Quadratic in the count, so meant for at most kRankSortMax candidates.
#include <cstddef>

#include "pointfair/types.hpp"

namespace pointfair {

/// The scans of the neighbour search: plain (SSE2 on x86-64, scalar elsewhere) or AVX2.
enum class KnnKernel {
  Plain,
  Avx2,  ///< x86-64 CPUs with AVX2, checked at run time
};

/// True if this build and CPU can run `kernel` (Plain always).
bool knn_kernel_available(KnnKernel kernel);

/// Avx2 where available, unless the environment variable POINTFAIR_NO_AVX2 is set (non-empty,
/// not "0"), as for the Euler step's kernel.
KnnKernel default_knn_kernel();

/// Most candidates rank_sort takes.
inline constexpr std::size_t kRankSortMax = 64;

/// Writes the n candidates (d2[i], id[i]) sorted by d2, ties by the smaller id, to out_d2 and
/// out_id (n entries each). n <= kRankSortMax; d2 holds no NaN and the ids are distinct and
/// below 2^32 - 1. `d2` must have room for n rounded up to a multiple of 4: the entries past n
/// are overwritten (padding).
void rank_sort(double* d2, const Index* id, std::size_t n, double* out_d2, Index* out_id,
               KnnKernel kernel = default_knn_kernel());

}  // namespace pointfair
