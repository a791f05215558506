#include "pointfair/neighbors/knn_grid.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
// AVX2 versions of the scans, chosen at run time: four squared distances or comparisons an
// instruction instead of two. Only adds, subtractions, multiplications and comparisons, each
// rounded as in the scalar code (no fused multiply-add), so every distance is the same bit for
// bit on either path.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define POINTFAIR_KNN_AVX2 1
#include <immintrin.h>
#endif

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/neighbors/kd_tree.hpp"
#include "pointfair/neighbors/knn_select.hpp"
#include "common/huge_pages.hpp"

namespace pointfair {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::int64_t kAxisCells = std::int64_t{1} << 21;
constexpr int kProbes = 16;
// Blocks of (2R+1)^3 cells are tried for R = 1 .. kMaxRing, each of at most the budget's points.
constexpr std::int64_t kMaxRing = 3;
// The queries they leave (points far off a thick noisy surface, blocks denser than the
// budget) are searched one at a time in blocks of up to kWideRing cells and kWideBudget points
// before the k-d tree: a 4M-point noisy cube (noise of 7 sample spacings) left 527 of them, and
// a tree over all its points took most of the build's time.
constexpr std::int64_t kWideRing = 24;
constexpr std::size_t kWideBudget = std::size_t{1} << 18;
// Cell size over the median distance to the k-th nearest point.
constexpr double kCellFactor = 1.1;
// With a finite eps below that, the cell is eps enlarged by this factor: a query anywhere in
// its cell then has its whole eps-ball inside the 3 x 3 x 3 block, despite the margins below.
constexpr double kEpsCellFactor = 1.0 + 1e-4;
// Margins of the exactness test, far above the rounding they cover: the cell coordinates
// (relative error ~1e-16 of at most 2^21 cells) and a computed squared distance (~1e-15).
constexpr double kGapMargin = 1e-6;  // cell units
constexpr double kRelativeMargin = 1e-9;
// Queries left to the fallback that a scan of every point answers (else a k-d tree is built).
constexpr std::size_t kScanLimit = 32;

// Squared distance summed in the k-d tree's order (x, y, z), so ties compare the same way.
inline double distance2(double qx, double qy, double qz, double px, double py, double pz) {
  const double dx = qx - px, dy = qy - py, dz = qz - pz;
  return dx * dx + dy * dy + dz * dz;
}

// How many of d2[0..m) are <= limit. SSE2 where available (the baseline of x86-64).
std::size_t count_within_sse2(const double* d2, std::size_t m, double limit) {
  std::size_t j = 0;
  std::size_t count = 0;
#if defined(__SSE2__)
  const __m128d bound = _mm_set1_pd(limit);
  __m128i lanes = _mm_setzero_si128();
  for (; j + 2 <= m; j += 2)
    lanes = _mm_sub_epi64(lanes, _mm_castpd_si128(_mm_cmple_pd(_mm_loadu_pd(d2 + j), bound)));
  std::int64_t sums[2];
  _mm_storeu_si128(reinterpret_cast<__m128i*>(sums), lanes);
  count = static_cast<std::size_t>(sums[0] + sums[1]);
#endif
  for (; j < m; ++j) count += d2[j] <= limit ? 1 : 0;
  return count;
}

// d[j] = |p_j - q|^2 for j < m, from coordinate arrays.
void distances_plain(const double* px, const double* py, const double* pz, std::size_t m,
                     double qx, double qy, double qz, double* d) {
  // p - q rather than q - p: the same squares, and no register copy of q per subtraction.
  for (std::size_t j = 0; j < m; ++j) d[j] = distance2(px[j], py[j], pz[j], qx, qy, qz);
}

#if defined(POINTFAIR_KNN_AVX2)
__attribute__((target("avx2"))) std::size_t count_within_avx2(const double* d2, std::size_t m,
                                                              double limit) {
  std::size_t j = 0;
  const __m256d bound = _mm256_set1_pd(limit);
  __m256i lanes = _mm256_setzero_si256();
  for (; j + 4 <= m; j += 4) {
    const __m256d le = _mm256_cmp_pd(_mm256_loadu_pd(d2 + j), bound, _CMP_LE_OQ);
    lanes = _mm256_sub_epi64(lanes, _mm256_castpd_si256(le));
  }
  alignas(32) std::int64_t sums[4];
  _mm256_store_si256(reinterpret_cast<__m256i*>(sums), lanes);
  auto count = static_cast<std::size_t>(sums[0] + sums[1] + sums[2] + sums[3]);
  for (; j < m; ++j) count += d2[j] <= limit ? 1 : 0;
  return count;
}

// Also returns how many of the distances are <= limit (the first count of the threshold).
__attribute__((target("avx2"))) std::size_t distances_avx2(const double* px, const double* py,
                                                           const double* pz, std::size_t m,
                                                           double qx, double qy, double qz,
                                                           double* d, double limit) {
  const __m256d vx = _mm256_set1_pd(qx), vy = _mm256_set1_pd(qy), vz = _mm256_set1_pd(qz);
  const __m256d bound = _mm256_set1_pd(limit);
  __m256i lanes = _mm256_setzero_si256();
  std::size_t j = 0;
  for (; j + 4 <= m; j += 4) {
    const __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(px + j), vx);
    const __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(py + j), vy);
    const __m256d dz = _mm256_sub_pd(_mm256_loadu_pd(pz + j), vz);
    // (dx^2 + dy^2) + dz^2, each rounded: the scalar order.
    const __m256d s = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
                                    _mm256_mul_pd(dz, dz));
    _mm256_storeu_pd(d + j, s);
    lanes = _mm256_sub_epi64(lanes, _mm256_castpd_si256(_mm256_cmp_pd(s, bound, _CMP_LE_OQ)));
  }
  alignas(32) std::int64_t sums[4];
  _mm256_store_si256(reinterpret_cast<__m256i*>(sums), lanes);
  auto count = static_cast<std::size_t>(sums[0] + sums[1] + sums[2] + sums[3]);
  for (; j < m; ++j) {
    d[j] = distance2(px[j], py[j], pz[j], qx, qy, qz);
    count += d[j] <= limit ? 1 : 0;
  }
  return count;
}

// The n candidates with d2[j] <= limit (n counted before), in order, to (to_d2, to_id); the
// outputs have room for n + 4. A table turns each comparison mask into the permutation that
// packs the selected lanes: no branch per candidate.
// One row a comparison mask, 64 bytes: one shifted index finds both permutations.
struct alignas(64) PackRow {
  std::int32_t d2[8];  // 32-bit halves of the selected doubles, first
  std::int32_t id[4];  // the selected indices, first
  std::int32_t count;  // how many are selected
  std::int32_t unused[3];
};

struct PackTable {
  PackRow row[16];
};

constexpr PackTable make_pack_table() {
  PackTable t{};
  for (int mask = 0; mask < 16; ++mask) {
    int o = 0;
    for (int lane = 0; lane < 4; ++lane) {
      if (((mask >> lane) & 1) == 0) continue;
      t.row[mask].d2[2 * o] = 2 * lane;
      t.row[mask].d2[2 * o + 1] = 2 * lane + 1;
      t.row[mask].id[o] = lane;
      ++o;
    }
    t.row[mask].count = o;
  }
  return t;
}

constexpr PackTable kPack = make_pack_table();

__attribute__((target("avx2"))) void pack_within_avx2(const double* d2, const Index* ids,
                                                              std::size_t m, double limit,
                                                              double* to_d2, Index* to_id) {
  const __m256d bound = _mm256_set1_pd(limit);
  std::size_t n = 0, j = 0;
  for (; j + 4 <= m; j += 4) {
    const __m256d v = _mm256_loadu_pd(d2 + j);
    const auto mask = static_cast<unsigned>(_mm256_movemask_pd(_mm256_cmp_pd(v, bound, _CMP_LE_OQ)));
    const PackRow& row = kPack.row[mask];
    const __m256i pd = _mm256_load_si256(reinterpret_cast<const __m256i*>(row.d2));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(to_d2 + n),
                        _mm256_permutevar8x32_epi32(_mm256_castpd_si256(v), pd));
    const __m128i pi = _mm_load_si128(reinterpret_cast<const __m128i*>(row.id));
    const __m128 vi = _mm_castsi128_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(ids + j)));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(to_id + n), _mm_castps_si128(_mm_permutevar_ps(vi, pi)));
    n += static_cast<std::size_t>(row.count);
  }
  for (; j < m; ++j) {
    to_d2[n] = d2[j];
    to_id[n] = ids[j];
    n += d2[j] <= limit ? 1 : 0;
  }
}
#endif

bool use_avx2() {
  static const bool yes = default_knn_kernel() == KnnKernel::Avx2;
  return yes;
}

void pack_within(const double* d2, const Index* ids, std::size_t m, double limit, double* to_d2,
                 Index* to_id) {
#if defined(POINTFAIR_KNN_AVX2)
  if (use_avx2()) return pack_within_avx2(d2, ids, m, limit, to_d2, to_id);
#endif
  std::size_t n = 0;
  for (std::size_t j = 0; j < m; ++j) {
    to_d2[n] = d2[j];
    to_id[n] = ids[j];
    n += d2[j] <= limit ? 1 : 0;
  }
}

#if defined(POINTFAIR_KNN_AVX2)
bool has_avx2() { return use_avx2(); }
#endif

std::size_t count_within(const double* d2, std::size_t m, double limit) {
#if defined(POINTFAIR_KNN_AVX2)
  if (has_avx2()) return count_within_avx2(d2, m, limit);
#endif
  return count_within_sse2(d2, m, limit);
}

// d[j] = |p_j - q|^2 for j < m; returns how many are <= limit.
std::size_t distances(const double* px, const double* py, const double* pz, std::size_t m,
                      double qx, double qy, double qz, double* d, double limit) {
#if defined(POINTFAIR_KNN_AVX2)
  if (has_avx2()) return distances_avx2(px, py, pz, m, qx, qy, qz, d, limit);
#endif
  distances_plain(px, py, pz, m, qx, qy, qz, d);
  return count_within_sse2(d, m, limit);
}

struct Entry {
  double d2;
  Index id;
};

// The `cap` smallest (squared distance, index) pairs offered with distance <= bound, sorted by
// distance, ties by the smaller index: the k-d tree's canonical result set.
class Nearest {
 public:
  // `slots` holds cap + 1 entries; the first is a sentinel below every squared distance.
  Nearest(int cap, double bound, Entry* slots)
      : cap_(cap), worst_(bound), e_(slots + 1) {
    slots[0] = {-1.0, 0};
  }

  int count() const { return count_; }
  bool full() const { return count_ == cap_; }
  double last() const { return e_[count_ - 1].d2; }
  const Entry* entries() const { return e_; }

  // Takes the first entries of n pairs already sorted and within the bound.
  void assign_sorted(const double* d2, const Index* ids, std::size_t n) {
    count_ = static_cast<int>(std::min<std::size_t>(n, static_cast<std::size_t>(cap_)));
    for (int j = 0; j < count_; ++j) e_[j] = {d2[j], ids[j]};
    if (count_ == cap_) worst_ = e_[cap_ - 1].d2;
  }

  // Offers the pairs with d2[j] <= limit (<= the bound): a vectorised scan that finds the few
  // of them without a branch per candidate.
  void offer_within(const double* d2, const Index* ids, std::size_t m, double limit) {
#if defined(POINTFAIR_KNN_AVX2)
    if (has_avx2()) {
      offer_within_avx2(d2, ids, m, limit);
      return;
    }
#endif
    std::size_t j = 0;
#if defined(__SSE2__)
    const __m128d bound = _mm_set1_pd(limit);
    for (; j + 2 <= m; j += 2) {
      const int mask = _mm_movemask_pd(_mm_cmple_pd(_mm_loadu_pd(d2 + j), bound));
      if (mask == 0) continue;
      if ((mask & 1) != 0 && !(d2[j] > worst_)) insert(d2[j], ids[j]);
      if ((mask & 2) != 0 && !(d2[j + 1] > worst_)) insert(d2[j + 1], ids[j + 1]);
    }
#endif
    for (; j < m; ++j)
      if (d2[j] <= limit && !(d2[j] > worst_)) insert(d2[j], ids[j]);
  }

  void offer(const double* d2, const Index* ids, std::size_t m) {
    for (std::size_t j = 0; j < m; ++j) {
      if (d2[j] > worst_) continue;
      insert(d2[j], ids[j]);
    }
  }

 private:
  void insert(double d, Index id) {
    int p = 0;
    if (count_ == cap_) {
      if (d == worst_ && id > e_[cap_ - 1].id) return;
      p = cap_ - 1;
    } else {
      p = count_++;
    }
    // The sentinel e_[-1] stops the walk.
    while (e_[p - 1].d2 > d || (e_[p - 1].d2 == d && e_[p - 1].id > id)) {
      e_[p] = e_[p - 1];
      --p;
    }
    e_[p] = {d, id};
    if (count_ == cap_) worst_ = e_[cap_ - 1].d2;
  }

#if defined(POINTFAIR_KNN_AVX2)
  __attribute__((target("avx2"))) void offer_within_avx2(const double* d2, const Index* ids,
                                                         std::size_t m, double limit) {
    const __m256d bound = _mm256_set1_pd(limit);
    std::size_t j = 0;
    for (; j + 4 <= m; j += 4) {
      auto mask = static_cast<unsigned>(
          _mm256_movemask_pd(_mm256_cmp_pd(_mm256_loadu_pd(d2 + j), bound, _CMP_LE_OQ)));
      while (mask != 0) {
        const std::size_t i = j + static_cast<std::size_t>(std::countr_zero(mask));
        mask &= mask - 1;
        if (!(d2[i] > worst_)) insert(d2[i], ids[i]);
      }
    }
    for (; j < m; ++j)
      if (d2[j] <= limit && !(d2[j] > worst_)) insert(d2[j], ids[j]);
  }
#endif

  int cap_;
  double worst_;
  Entry* e_;
  int count_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Building the grid.

struct Box {
  double lo[3] = {kInf, kInf, kInf};
  double hi[3] = {-kInf, -kInf, -kInf};
};

Box bounding_box(std::span<const Vec3> points) {
  Box b;
  for (const Vec3& p : points) {
    for (int a = 0; a < 3; ++a) {
      b.lo[a] = std::min(b.lo[a], p[a]);
      b.hi[a] = std::max(b.hi[a], p[a]);
    }
  }
  return b;
}

// Per axis, from an evenly strided sample of at most 4096 points: the median and the spread
// between the 1% and 99% quantiles (robust to a few far outliers).
struct RobustSpread {
  double median[3] = {0, 0, 0};
  double extent = 0;  // largest spread over the axes
};

RobustSpread robust_spread(std::span<const Vec3> points) {
  const std::size_t n = points.size();
  const std::size_t stride = std::max<std::size_t>(1, n / 4096);
  std::vector<double> v((n + stride - 1) / stride);
  RobustSpread r;
  for (int a = 0; a < 3; ++a) {
    for (std::size_t s = 0; s < v.size(); ++s) v[s] = points[s * stride][a];
    const auto at = [&](std::size_t i) {
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(i), v.end());
      return v[i];
    };
    const std::size_t last = v.size() - 1;
    r.median[a] = at(v.size() / 2);
    r.extent = std::max(r.extent, at(last - last / 100) - at(last / 100));
  }
  return r;
}

// Median distance to the (want)-th nearest point (the point itself included) of kProbes evenly
// strided probe points, measured exactly by one pass over every `stride`-th point; the largest of
// them if the median is 0 (duplicates), 0 if every probe sits on more than `want` duplicates.
double probe_spacing(std::span<const Vec3> points, std::size_t want, std::size_t stride) {
  const std::size_t n = points.size();
  const std::size_t samples = (n + stride - 1) / stride;
  double px[kProbes], py[kProbes], pz[kProbes];
  for (std::size_t p = 0; p < kProbes; ++p) {
    const Vec3& q = points[(2 * p + 1) * n / (2 * kProbes)];
    px[p] = q.x();
    py[p] = q.y();
    pz[p] = q.z();
  }
  // Each chunk keeps, per probe, a max-heap of the `want` smallest squared distances it saw.
  const std::size_t chunks = std::min<std::size_t>(64, (samples + 16383) / 16384);
  std::vector<double> heaps(chunks * kProbes * want, kInf);
  parallel_for(chunks, [&](std::size_t cb, std::size_t ce) {
    for (std::size_t c = cb; c < ce; ++c) {
      double* heap = heaps.data() + c * kProbes * want;
      double top[kProbes];
      std::fill(top, top + kProbes, kInf);
      const std::size_t end = (c + 1) * samples / chunks;
      for (std::size_t sample = c * samples / chunks; sample < end; ++sample) {
        const Vec3& point = points[sample * stride];
        const double x = point.x(), y = point.y(), z = point.z();
        double d[kProbes];
        bool any = false;
        for (std::size_t p = 0; p < kProbes; ++p) {
          d[p] = distance2(px[p], py[p], pz[p], x, y, z);
          any |= d[p] < top[p];
        }
        if (!any) continue;
        for (std::size_t p = 0; p < kProbes; ++p) {
          if (!(d[p] < top[p])) continue;
          double* h = heap + p * want;
          std::pop_heap(h, h + want);
          h[want - 1] = d[p];
          std::push_heap(h, h + want);
          top[p] = h[0];
        }
      }
    }
  }, 1);
  std::vector<double> spacing(kProbes);
  std::vector<double> all(chunks * want);
  for (std::size_t p = 0; p < kProbes; ++p) {
    for (std::size_t c = 0; c < chunks; ++c)
      std::copy_n(heaps.data() + (c * kProbes + p) * want, want, all.data() + c * want);
    std::nth_element(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(want - 1), all.end());
    spacing[p] = std::sqrt(all[want - 1]);
  }
  std::sort(spacing.begin(), spacing.end());
  const double median = spacing[kProbes / 2];
  return median > 0.0 ? median : spacing.back();
}

// The cell edge length for searches of `want` points within eps; +infinity for one cell.
double choose_cell(std::span<const Vec3> points, std::size_t want, double eps, const Box& box,
                   const RobustSpread& spread) {
  const std::size_t n = points.size();
  // Small clouds: every query against every point is cheap enough.
  if (n <= 2 * want + 64) return kInf;
  // Large clouds: every second (fourth) point, and half (a quarter) as many of them, measure
  // about the same distance at half (a quarter of) the cost (the cell size only affects
  // speed, never the lists).
  const std::size_t stride = n >= 65536 && want >= 16 ? 4 : n >= 8192 && want >= 8 ? 2 : 1;
  double cell = kCellFactor * probe_spacing(points, (want + stride - 1) / stride, stride);
  if (!(cell > 0.0)) {
    // The probes all sit on stacks of duplicates: a cell per point on average.
    double extent = 0.0;
    for (int a = 0; a < 3; ++a) extent = std::max(extent, box.hi[a] - box.lo[a]);
    cell = extent / std::cbrt(static_cast<double>(n));
  }
  if (std::isfinite(eps)) cell = std::min(cell, eps * kEpsCellFactor);
  // Keep the bulk of the cloud inside the 2^21 cells of the window.
  cell = std::max(cell, spread.extent * 0x1p-19);
  if (!(cell > 0.0) || !std::isfinite(cell)) return kInf;
  return cell;
}

std::int64_t cell_coordinate(const CellGrid& g, double v, int a) {
  const double u = (v - g.origin[a]) * g.inverse_cell;
  if (!(u > 0.0)) return 0;
  const double top = static_cast<double>(g.dims[a] - 1);
  return u >= top ? g.dims[a] - 1 : static_cast<std::int64_t>(u);
}

// Stable LSD radix sort of `keys` (values < 2^bits) carrying `values` along.
void radix_sort(std::vector<std::uint64_t>& keys, std::vector<Index>& values, int bits) {
  constexpr int kDigit = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigit;
  const int passes = (bits + kDigit - 1) / kDigit;
  if (passes == 0) return;
  const std::size_t n = keys.size();
  std::vector<std::size_t> counts(static_cast<std::size_t>(passes) * kBuckets, 0);
  for (const std::uint64_t key : keys)
    for (int p = 0; p < passes; ++p)
      ++counts[static_cast<std::size_t>(p) * kBuckets + ((key >> (p * kDigit)) & (kBuckets - 1))];
  std::vector<std::uint64_t> keys2;
  std::vector<Index> values2;
  detail::assign_huge(keys2, n, std::uint64_t{0});
  detail::assign_huge(values2, n, Index{0});
  for (int p = 0; p < passes; ++p) {
    std::size_t* count = counts.data() + static_cast<std::size_t>(p) * kBuckets;
    if (std::find(count, count + kBuckets, n) != count + kBuckets) continue;  // one digit only
    std::size_t sum = 0;
    for (std::size_t b = 0; b < kBuckets; ++b) sum += std::exchange(count[b], sum);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t to = count[(keys[i] >> (p * kDigit)) & (kBuckets - 1)]++;
      keys2[to] = keys[i];
      values2[to] = values[i];
    }
    keys.swap(keys2);
    values.swap(values2);
  }
}

}  // namespace

CellGrid build_cell_grid(std::span<const Vec3> points, int k, double eps) {
  require(k >= 1 && k <= 1024, "k must be in 1..1024, got " + std::to_string(k));
  require(eps > 0.0, "eps must be positive");
  require(points.size() < std::numeric_limits<Index>::max(),
          "an in-core cloud holds fewer than 2^32-1 points; use tiles for more");
  require_finite(points, "neighbourhoods");
  CellGrid g;
  g.points = points;
  const std::size_t n = points.size();
  g.starts.assign(1, 0);
  if (n == 0) return g;

  const Box box = bounding_box(points);
  const RobustSpread spread = robust_spread(points);
  g.cell = choose_cell(points, static_cast<std::size_t>(k) + 1, eps, box, spread);
  for (int a = 0; a < 3; ++a) g.origin[a] = box.lo[a];
  if (std::isfinite(g.cell)) {
    g.inverse_cell = 1.0 / g.cell;
    const double half = static_cast<double>(kAxisCells / 2) * g.cell;
    for (int a = 0; a < 3; ++a) {
      g.origin[a] = std::max(box.lo[a], spread.median[a] - half);
      const double span = (box.hi[a] - g.origin[a]) * g.inverse_cell;
      g.dims[a] = span >= static_cast<double>(kAxisCells - 1) ? kAxisCells
                                                              : static_cast<std::int64_t>(span) + 1;
    }
  }

  // Cell keys, then the points sorted by key (ties by index: the sort is stable).
  std::vector<std::uint64_t> keys;
  detail::assign_huge(keys, n, std::uint64_t{0});
  detail::assign_huge(g.order, n, Index{0});
  parallel_for(n, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const Vec3& p = points[i];
      const std::int64_t cx = cell_coordinate(g, p.x(), 0), cy = cell_coordinate(g, p.y(), 1),
                         cz = cell_coordinate(g, p.z(), 2);
      keys[i] = static_cast<std::uint64_t>((cz * g.dims[1] + cy) * g.dims[0] + cx);
      g.order[i] = static_cast<Index>(i);
    }
  }, 16384);
  const auto max_key = static_cast<std::uint64_t>(g.dims[0] * g.dims[1] * g.dims[2] - 1);
  radix_sort(keys, g.order, static_cast<int>(std::bit_width(max_key)));

  detail::assign_huge(g.x, n, 0.0);
  detail::assign_huge(g.y, n, 0.0);
  detail::assign_huge(g.z, n, 0.0);
  parallel_for(n, [&](std::size_t b, std::size_t e) {
    for (std::size_t s = b; s < e; ++s) {
      const Vec3& p = points[g.order[s]];
      g.x[s] = p.x();
      g.y[s] = p.y();
      g.z[s] = p.z();
    }
  }, 16384);
  g.starts.clear();
  for (std::size_t s = 0; s < n; ++s) {
    if (s > 0 && keys[s] == keys[s - 1]) continue;
    g.keys.push_back(keys[s]);
    g.starts.push_back(static_cast<Index>(s));
  }
  g.starts.push_back(static_cast<Index>(n));
  return g;
}

// ---------------------------------------------------------------------------------------------
// Searching.

namespace {

// The queries of a search sorted by grid position, grouped by cell. For every point (the
// build's usual case) entry e is grid position e, its row row_of[order[e]] (order[e] without
// row_of) and query cell c grid cell c: computed when asked rather than stored, which keeps
// 8 bytes a point off the build's peak memory.
struct Queries {
  const CellGrid* every = nullptr;  // every point of this grid, or the lists below
  std::span<const Index> row_of;    // with `every`: the row of each point (empty: itself)
  std::vector<Index> pos_list;      // sorted position of the query point
  std::vector<Index> row_list;      // its output row
  std::vector<Index> cell_list;     // query cells: grid cell index ...
  std::vector<Index> first_list;    // ... and their entries first[c] .. first[c+1]-1

  std::size_t size() const { return every ? every->size() : pos_list.size(); }
  std::size_t cells() const { return every ? every->keys.size() : cell_list.size(); }
  std::size_t pos(std::size_t e) const { return every ? e : pos_list[e]; }
  Index row(std::size_t e) const {
    if (!every) return row_list[e];
    const Index point = every->order[e];
    return row_of.empty() ? point : row_of[point];
  }
  std::size_t cell(std::size_t c) const { return every ? c : cell_list[c]; }
  Index first(std::size_t c) const { return every ? every->starts[c] : first_list[c]; }
};

Queries every_point(const CellGrid& g, std::span<const Index> row_of) {
  Queries q;
  q.every = &g;
  q.row_of = row_of;
  return q;
}

Queries some_points(const CellGrid& g, std::span<const Index> queries) {
  const std::size_t n = g.size();
  std::vector<Index> position_of(n);
  parallel_for(n, [&](std::size_t b, std::size_t e) {
    for (std::size_t s = b; s < e; ++s) position_of[g.order[s]] = static_cast<Index>(s);
  }, 16384);
  std::vector<std::uint64_t> keys(queries.size());
  Queries q;
  q.row_list.resize(queries.size());
  for (std::size_t r = 0; r < queries.size(); ++r) {
    require(queries[r] < n, "query " + std::to_string(queries[r]) + " is not a point index");
    keys[r] = position_of[queries[r]];
    q.row_list[r] = static_cast<Index>(r);
  }
  radix_sort(keys, q.row_list, n <= 1 ? 0 : static_cast<int>(std::bit_width(static_cast<std::uint64_t>(n - 1))));
  q.pos_list.assign(keys.begin(), keys.end());
  std::size_t c = 0;
  for (std::size_t e = 0; e < q.pos_list.size(); ++e) {
    while (g.starts[c + 1] <= q.pos_list[e]) ++c;
    if (q.cell_list.empty() || q.cell_list.back() != c) {
      q.cell_list.push_back(static_cast<Index>(c));
      q.first_list.push_back(static_cast<Index>(e));
    }
  }
  q.first_list.push_back(static_cast<Index>(q.pos_list.size()));
  return q;
}

// Candidate points copied out of the grid: coordinates, indices, and their squared distances
// to the current query.
struct Candidates {
  std::vector<double> x, y, z, d2;
  std::vector<Index> id;
  std::size_t m = 0;

  void append(const CellGrid& g, std::size_t from, std::size_t to) {
    const std::size_t add = to - from;
    if (x.size() < m + add) {
      const std::size_t size = std::max(2 * x.size(), m + add);
      x.resize(size);
      y.resize(size);
      z.resize(size);
      d2.resize(size);
      id.resize(size);
    }
    // One loop over the four arrays: the rows are short (a few cells), and four library
    // copies per row cost more in calls than in bytes.
    const double *gx = g.x.data() + from, *gy = g.y.data() + from, *gz = g.z.data() + from;
    const Index* go = g.order.data() + from;
    double *tx = x.data() + m, *ty = y.data() + m, *tz = z.data() + m;
    Index* to_id = id.data() + m;
    std::size_t j = 0;
#if defined(__SSE2__)
    for (; j + 2 <= add; j += 2) {
      _mm_storeu_pd(tx + j, _mm_loadu_pd(gx + j));
      _mm_storeu_pd(ty + j, _mm_loadu_pd(gy + j));
      _mm_storeu_pd(tz + j, _mm_loadu_pd(gz + j));
      _mm_storel_epi64(reinterpret_cast<__m128i*>(to_id + j),
                       _mm_loadl_epi64(reinterpret_cast<const __m128i*>(go + j)));
    }
    if (j < add) {  // at most one left
#else
    for (; j < add; ++j) {
#endif
      tx[j] = gx[j];
      ty[j] = gy[j];
      tz[j] = gz[j];
      to_id[j] = go[j];
    }
    m += add;
  }

  // Returns how many are <= limit.
  std::size_t distances(double qx, double qy, double qz, double limit = -1.0) {
    return pointfair::distances(x.data(), y.data(), z.data(), m, qx, qy, qz, d2.data(), limit);
  }
};

// One task's buffers.
struct Scratch {
  Candidates block;  // the points of the current cell's block
  Candidates extra;  // one query's points beyond the block
  std::vector<Entry> best;  // want + 1 entries (a sentinel first)
  std::vector<Index> ids;   // want indices
  // The block's candidates within the threshold, packed, then sorted.
  alignas(32) double packed_d2[kRankSortMax + 8];
  Index packed_id[kRankSortMax + 8];
  double sorted_d2[kRankSortMax];
  Index sorted_id[kRankSortMax];
  // The same for more candidates than the rank sort takes.
  std::vector<double> large_d2;
  std::vector<Index> large_id;
  std::vector<Entry> large;
  std::vector<std::uint32_t> bucket_start;  // bucket_sort's counts, then starts
  std::vector<Index> pending, still;
  double guess = 0.0;  // squared distance: the first selection threshold
};

// The rows (dy, dz) of the 3 x 3 x 3 block, the centre first.
constexpr int kRows1[9][2] = {{0, 0}, {-1, 0}, {1, 0}, {0, -1}, {0, 1}, {-1, -1}, {1, -1}, {-1, 1}, {1, 1}};

class Search {
 public:
  // `wide`: the search of the queries the first one left (kWideRing, kWideBudget).
  Search(const CellGrid& g, const Queries& q, int k, double eps, Neighborhoods& out,
         std::span<double> last_d2, std::vector<std::uint8_t>& unresolved, bool wide = false)
      : g_(g), q_(q), k_(k), want_(k + 1), max_d2_(std::isinf(eps) ? eps : eps * eps),
        max_ring_(wide ? kWideRing : kMaxRing),
        budget_(wide ? kWideBudget : std::max<std::size_t>(2048, 48 * static_cast<std::size_t>(k + 1))),
        floor_d2_(std::isfinite(g.cell) ? 1e-6 * g.cell * g.cell : kInf),
        out_(out), last_d2_(last_d2), unresolved_(unresolved), kernel_(default_knn_kernel()) {}

  // Query cells [cb, ce) of q. Each cell's queries are first searched in the 3 x 3 x 3 block
  // around it; a query whose result could still miss a point beyond the block also searches
  // the cells of its own reach; queries that find too few points try wider blocks.
  void run(std::size_t cb, std::size_t ce) const {
    Scratch s;
    s.best.resize(static_cast<std::size_t>(want_) + 1);
    s.ids.resize(static_cast<std::size_t>(want_));
    s.guess = std::isfinite(g_.cell) ? g_.cell * g_.cell : kInf;
    std::size_t cursor[9];
    std::fill(cursor, cursor + 9, kNoCursor);
    for (std::size_t qc = cb; qc < ce; ++qc) {
      const std::size_t c = q_.cell(qc);
      const std::uint64_t key = g_.keys[c];
      const auto d0 = static_cast<std::uint64_t>(g_.dims[0]), d1 = static_cast<std::uint64_t>(g_.dims[1]);
      const std::int64_t cell[3] = {static_cast<std::int64_t>(key % d0),
                                    static_cast<std::int64_t>((key / d0) % d1),
                                    static_cast<std::int64_t>(key / (d0 * d1))};
      s.pending.clear();
      for (Index e = q_.first(qc); e < q_.first(qc + 1); ++e) s.pending.push_back(e);
      // The next cell's output rows lie anywhere (rows in input order): their lines are
      // fetched while this cell is searched.
      if (qc + 1 < ce)
        for (Index e = q_.first(qc + 1); e < q_.first(qc + 2); ++e) prefetch_row(q_.row(e));
      for (std::int64_t ring = 1; ring <= max_ring_ && !s.pending.empty(); ++ring) {
        if (!gather(s.block, cell, ring, ring == 1 ? cursor : nullptr)) break;
        s.still.clear();
        for (const Index e : s.pending)
          if (!answer(s, e, cell, ring)) s.still.push_back(e);
        s.pending.swap(s.still);
      }
      for (const Index e : s.pending) unresolved_[e] = 1;
    }
  }

  // Queries entries[b, e) one at a time, each in blocks of radius 1 .. max_ring_ around its
  // cell; unresolved_ is cleared for those settled.
  void run_entries(std::span<const Index> entries, std::size_t b, std::size_t e) const {
    Scratch s;
    s.best.resize(static_cast<std::size_t>(want_) + 1);
    s.ids.resize(static_cast<std::size_t>(want_));
    s.guess = std::isfinite(g_.cell) ? g_.cell * g_.cell : kInf;
    for (std::size_t i = b; i < e; ++i) {
      const Index entry = entries[i];
      const std::size_t pos = q_.pos(entry);
      const std::int64_t cell[3] = {cell_coordinate(g_, g_.x[pos], 0), cell_coordinate(g_, g_.y[pos], 1),
                                    cell_coordinate(g_, g_.z[pos], 2)};
      for (std::int64_t ring = 1; ring <= max_ring_; ++ring) {
        if (!gather(s.block, cell, ring, nullptr)) break;
        if (answer(s, entry, cell, ring)) {
          unresolved_[entry] = 0;
          break;
        }
      }
    }
  }

  // The queries the grid left: through `tree`, a scan of every point, or a tree built here.
  void fallback(std::span<const Index> entries, const KdTree* tree) const {
    if (entries.empty()) return;
    std::unique_ptr<KdTree> own;
    if (tree == nullptr && entries.size() > kScanLimit) {
      own = std::make_unique<KdTree>(g_.points);
      tree = own.get();
    }
    parallel_for(entries.size(), [&](std::size_t b, std::size_t e) {
      std::vector<double> best_d2(static_cast<std::size_t>(want_));
      std::vector<Index> best_id(static_cast<std::size_t>(want_));
      std::vector<Entry> best(static_cast<std::size_t>(want_) + 1);
      std::vector<double> d2;
      for (std::size_t i = b; i < e; ++i) {
        const std::size_t pos = q_.pos(entries[i]);
        const Index self = g_.order[pos];
        int found = 0;
        if (tree != nullptr) {
          found = tree->nearest(g_.points[self], want_, max_d2_, best_id.data(), best_d2.data());
          for (std::size_t j = 0; j < static_cast<std::size_t>(found); ++j) best[j + 1] = {best_d2[j], best_id[j]};
        } else {
          Nearest nearest(want_, max_d2_, best.data());
          constexpr std::size_t kBlock = 1024;
          d2.resize(kBlock);
          for (std::size_t from = 0; from < g_.size(); from += kBlock) {
            const std::size_t m = std::min(kBlock, g_.size() - from);
            for (std::size_t j = 0; j < m; ++j)
              d2[j] = distance2(g_.x[pos], g_.y[pos], g_.z[pos], g_.x[from + j], g_.y[from + j],
                                g_.z[from + j]);
            nearest.offer(d2.data(), g_.order.data() + from, m);
          }
          found = nearest.count();
        }
        write_row(q_.row(entries[i]), self, best.data() + 1, found, best_id.data());
      }
    }, 1);
  }

 private:
  static constexpr std::size_t kNoCursor = std::numeric_limits<std::size_t>::max();

  std::uint64_t key(std::int64_t cx, std::int64_t cy, std::int64_t cz) const {
    return static_cast<std::uint64_t>((cz * g_.dims[1] + cy) * g_.dims[0] + cx);
  }

  // Cell coordinate of a position u in cell units (clamped into the grid, as the points are).
  std::int64_t clamp_cell(double u, int a) const {
    if (!(u > 0.0)) return 0;
    const double top = static_cast<double>(g_.dims[a] - 1);
    return u >= top ? g_.dims[a] - 1 : static_cast<std::int64_t>(u);
  }

  // First cell with a key >= k, at or after `from` (all keys before `from` are < k).
  std::size_t seek(std::uint64_t k, std::size_t from) const {
    const std::size_t count = g_.keys.size();
    if (from == kNoCursor) {
      return static_cast<std::size_t>(std::lower_bound(g_.keys.begin(), g_.keys.end(), k) -
                                      g_.keys.begin());
    }
    if (from >= count || g_.keys[from] >= k) return from;
    // Galloping: keys[lo] < k; double the step until a key >= k (or the end) is passed.
    std::size_t lo = from, step = 1;
    while (lo + step < count && g_.keys[lo + step] < k) {
      lo += step;
      step *= 2;
    }
    const std::size_t hi = std::min(count, lo + step);
    return static_cast<std::size_t>(
        std::lower_bound(g_.keys.begin() + static_cast<std::ptrdiff_t>(lo + 1),
                         g_.keys.begin() + static_cast<std::ptrdiff_t>(hi), k) -
        g_.keys.begin());
  }

  // Appends the points of cells x0..x1 of row (y, z) to `to`; `cursor` is a position at or
  // before the row's first cell (kNoCursor: unknown) and is moved to it.
  void add_row(Candidates& to, std::int64_t x0, std::int64_t x1, std::int64_t y, std::int64_t z,
               std::size_t& cursor) const {
    if (x0 > x1 || y < 0 || y >= g_.dims[1] || z < 0 || z >= g_.dims[2]) return;
    const std::uint64_t lo = key(x0, y, z), hi = key(x1, y, z);
    const std::size_t a = seek(lo, cursor);
    cursor = a;
    std::size_t b = a;
    while (b < g_.keys.size() && g_.keys[b] <= hi) ++b;
    if (b > a) to.append(g_, g_.starts[a], g_.starts[b]);
  }

  // Collects the points of the block of radius `ring` around `cell`; false if they are more
  // than the budget (the queries then go to the fallback). With `cursor` (ring 1), each row
  // resumes from its position for the previous cell: the rows of consecutive cells move forward.
  bool gather(Candidates& to, const std::int64_t* cell, std::int64_t ring, std::size_t* cursor) const {
    to.m = 0;
    const std::int64_t x0 = std::max<std::int64_t>(cell[0] - ring, 0);
    const std::int64_t x1 = std::min<std::int64_t>(cell[0] + ring, g_.dims[0] - 1);
    if (cursor != nullptr) {
      for (std::size_t r = 0; r < 9; ++r) {
        add_row(to, x0, x1, cell[1] + kRows1[r][0], cell[2] + kRows1[r][1], cursor[r]);
        if (to.m > budget_) return false;
      }
      return true;
    }
    for (std::int64_t z = cell[2] - ring; z <= cell[2] + ring; ++z) {
      std::size_t at = kNoCursor;  // the rows of one z ascend
      for (std::int64_t y = cell[1] - ring; y <= cell[1] + ring; ++y) {
        add_row(to, x0, x1, y, z, at);
        if (to.m > budget_) return false;
      }
    }
    return true;
  }

  // Searches query entry e among the gathered block (and, if needed, the cells of its reach
  // beyond it); writes its row and returns true once the result is certainly exact.
  bool answer(Scratch& s, Index e, const std::int64_t* cell, std::int64_t ring) const {
    const std::size_t pos = q_.pos(e);
    const double q[3] = {g_.x[pos], g_.y[pos], g_.z[pos]};
    Candidates& block = s.block;

    // Only the candidates within a threshold t enter the (quadratic) sorted insertion: t is
    // refined, counting in one vectorised pass each time, until between want and want + slack
    // candidates lie within it (or every candidate within the bound). It starts from the
    // previous query's want-th distance, a little enlarged: consecutive queries are neighbours.
    const std::size_t want = static_cast<std::size_t>(want_);
    const std::size_t slack = std::max<std::size_t>(4, want / 2);
    const std::size_t m = block.m;
    const double* d2 = block.d2.data();
    const auto within = [&](double limit) { return count_within(d2, m, limit); };
    double t = std::min(s.guess, max_d2_);
    double below = 0.0, above = kInf;  // thresholds with fewer than want / too many within
    std::size_t c = block.distances(q[0], q[1], q[2], t);
    for (int round = 0; round < 6; ++round) {
      double next = 0.0;
      if (c < want) {
        if (c == m || !(t < max_d2_)) break;
        below = t;
        if (above < kInf) {
          next = std::sqrt(below * above);
        } else if (c > 0) {
          // As below: aim at want + slack / 2, growing at most 4-fold.
          const double ratio = static_cast<double>(want + slack / 2) / static_cast<double>(c);
          next = std::min(4.0, ratio * std::sqrt(std::sqrt(ratio))) * t;  // ratio^1.25
        } else {
          next = std::max(4.0 * t, floor_d2_);
        }
      } else if (c > want + slack) {
        above = t;
        // Counts grow about like t^(dimension / 2): aim at want + slack / 2.
        const double ratio = static_cast<double>(want + slack / 2) / static_cast<double>(c);
        next = t * std::sqrt(ratio * std::sqrt(ratio));  // ratio^0.75
        if (!(next > below)) next = below > 0.0 ? std::sqrt(below * above) : 0.5 * above;
      } else {
        break;
      }
      t = std::min(next, max_d2_);
      c = within(t);
    }
    if (c < want && c < m && t < max_d2_) {
      t = std::min(above, max_d2_);
      c = within(t);
    }
    // c candidates lie within t: packed and sorted by rank when they are few (the usual case),
    // else inserted one by one.
    // The row is written straight from the sorted candidates when the block settles it.
    Nearest nearest(want_, max_d2_, s.best.data());
    if (c <= kRankSortMax) {
      pack_within(d2, block.id.data(), m, t, s.packed_d2, s.packed_id);
      rank_sort(s.packed_d2, s.packed_id, c, s.sorted_d2, s.sorted_id, kernel_);
      const std::size_t found = std::min(c, want);
      const double last = found > 0 ? s.sorted_d2[found - 1] : 0.0;
      if (within_block(q, cell, ring, found == want ? last : max_d2_)) {
        if (found == want) s.guess = 1.15 * last;
        write_row(q_.row(e), g_.order[pos], s.sorted_id, static_cast<int>(found), last);
        return true;
      }
      nearest.assign_sorted(s.sorted_d2, s.sorted_id, c);
    } else {
      // Too many for the rank sort (a large k): the nearest `want` of them by a partial sort
      // in the same canonical order, instead of inserting each into a sorted list.
      const std::size_t found = std::min(c, want);
      select_nearest(s, d2, block.id.data(), m, t, c, found);
      const double last = found > 0 ? s.large_d2[found - 1] : 0.0;
      if (within_block(q, cell, ring, found == want ? last : max_d2_)) {
        if (found == want) s.guess = 1.15 * last;
        write_row(q_.row(e), g_.order[pos], s.large_id.data(), static_cast<int>(found), last);
        return true;
      }
      nearest.assign_sorted(s.large_d2.data(), s.large_id.data(), found);
    }

    if (!within_block(q, cell, ring, nearest.full() ? nearest.last() : max_d2_) &&
        !extend(s, q, cell, ring, nearest))
      return false;
    if (nearest.full()) s.guess = 1.15 * nearest.last();
    write_row(q_.row(e), g_.order[pos], nearest.entries(), nearest.count(), s.ids.data());
    return true;
  }

  // The `found` nearest of the c candidates within t (d2, ids: m of them), ascending by
  // distance, ties by the smaller index (the order Nearest keeps), into s.large_d2/large_id.
  static void select_nearest(Scratch& s, const double* d2, const Index* ids, std::size_t m, double t,
                             std::size_t c, std::size_t found) {
    s.large_d2.resize(c + 8);
    s.large_id.resize(c + 8);
    pack_within(d2, ids, m, t, s.large_d2.data(), s.large_id.data());
    s.large.resize(c);
    const auto closer = [](const Entry& a, const Entry& b) { return a.d2 < b.d2 || (a.d2 == b.d2 && a.id < b.id); };
    if (t > 0.0 && t < kInf) {
      bucket_sort(s, t, c);
    } else {
      for (std::size_t j = 0; j < c; ++j) s.large[j] = {s.large_d2[j], s.large_id[j]};
      const auto end = s.large.begin() + static_cast<std::ptrdiff_t>(found);
      std::nth_element(s.large.begin(), end, s.large.end(), closer);
      std::sort(s.large.begin(), end, closer);
    }
    for (std::size_t j = 0; j < found; ++j) {
      s.large_d2[j] = s.large[j].d2;
      s.large_id[j] = s.large[j].id;
    }
  }

  // The c packed candidates (s.large_d2, s.large_id; each d2 in [0, t]) into s.large in the
  // order of `closer` in select_nearest: a counting sort into about one bucket a candidate by
  // d2 / t (monotone in d2, so only candidates in one bucket can be out of order), then an
  // insertion sort, which only has those few to move. Linear where the comparison sorts it
  // replaces spent most of a large-k search in mispredicted branches.
  static void bucket_sort(Scratch& s, double t, std::size_t c) {
    const std::size_t buckets = std::max<std::size_t>(c, 1);
    const double scale = static_cast<double>(buckets) / t;
    const auto bucket_of = [&](double d2) {
      return std::min(buckets - 1, static_cast<std::size_t>(d2 * scale));
    };
    s.bucket_start.assign(buckets + 1, 0);
    for (std::size_t j = 0; j < c; ++j) ++s.bucket_start[bucket_of(s.large_d2[j]) + 1];
    for (std::size_t b = 0; b < buckets; ++b) s.bucket_start[b + 1] += s.bucket_start[b];
    for (std::size_t j = 0; j < c; ++j)
      s.large[s.bucket_start[bucket_of(s.large_d2[j])]++] = {s.large_d2[j], s.large_id[j]};
    for (std::size_t j = 1; j < c; ++j) {
      const Entry e = s.large[j];
      std::size_t i = j;
      for (; i > 0 && (e.d2 < s.large[i - 1].d2 || (e.d2 == s.large[i - 1].d2 && e.id < s.large[i - 1].id)); --i)
        s.large[i] = s.large[i - 1];
      s.large[i] = e;
    }
  }

  // True if no point outside the block could enter the result: the want-th distance (or the
  // bound, when fewer were found) is below the distance from q to the block's boundary. Sides
  // at the grid's border have nothing beyond them (border cells hold every point clamped in).
  bool within_block(const double* q, const std::int64_t* cell, std::int64_t ring,
                    double needed) const {
    double gap = kInf;  // in cells
    for (int a = 0; a < 3; ++a) {
      const double u = (q[a] - g_.origin[a]) * g_.inverse_cell;
      if (cell[a] - ring > 0) gap = std::min(gap, u - static_cast<double>(cell[a] - ring));
      if (cell[a] + ring < g_.dims[a] - 1) gap = std::min(gap, static_cast<double>(cell[a] + ring + 1) - u);
    }
    if (!(gap < kInf)) return true;
    // Every point outside the block has a squared distance of at least `outside`.
    const double reach = (gap - kGapMargin) * g_.cell;
    if (!(reach > 0.0)) return false;
    const double outside = reach * reach * (1.0 - kRelativeMargin);
    return needed < outside;
  }

  // Completes a result the block could not settle: offers the points of every cell that meets
  // the box q +- r and lies outside the block, r being the current want-th distance (or eps
  // when fewer were found). Every point left out is then farther than r. False if r is
  // unbounded or the box spans more than 2 max_ring_ + 1 cells on an axis.
  bool extend(Scratch& s, const double* q, const std::int64_t* cell, std::int64_t ring,
              Nearest& nearest) const {
    const double r2 = nearest.full() ? nearest.last() : max_d2_;
    if (!(r2 < kInf)) return false;
    const double reach = std::sqrt(r2) * g_.inverse_cell * (1.0 + kRelativeMargin) + kGapMargin;
    std::int64_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      const double u = (q[a] - g_.origin[a]) * g_.inverse_cell;
      lo[a] = clamp_cell(u - reach, a);
      hi[a] = clamp_cell(u + reach, a);
      if (hi[a] - lo[a] > 2 * max_ring_) return false;
    }
    Candidates& extra = s.extra;
    extra.m = 0;
    for (std::int64_t z = lo[2]; z <= hi[2]; ++z) {
      std::size_t at = kNoCursor;  // the rows of one z ascend
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y) {
        if (std::abs(y - cell[1]) <= ring && std::abs(z - cell[2]) <= ring) {
          // A row through the block: only its cells left and right of it.
          add_row(extra, lo[0], std::min(hi[0], cell[0] - ring - 1), y, z, at);
          add_row(extra, std::max(lo[0], cell[0] + ring + 1), hi[0], y, z, at);
        } else {
          add_row(extra, lo[0], hi[0], y, z, at);
        }
        if (extra.m > budget_) return false;
      }
    }
    extra.distances(q[0], q[1], q[2]);
    nearest.offer(extra.d2.data(), extra.id.data(), extra.m);
    return true;
  }

  void prefetch_row(std::size_t row) const {
    __builtin_prefetch(out_.indices.data() + row * static_cast<std::size_t>(k_), 1, 3);
    __builtin_prefetch(out_.counts.data() + row, 1, 3);
    if (!last_d2_.empty()) __builtin_prefetch(last_d2_.data() + row, 1, 3);
  }

  // `ids`: the found points in order; `last`: the squared distance of the last of them.
  void write_row(std::size_t row, Index self, const Index* ids, int found, double last) const {
    if (!last_d2_.empty()) last_d2_[row] = found > 0 ? last : 0.0;
    Index* dst = out_.indices.data() + row * static_cast<std::size_t>(k_);
    // The query itself is among the found points unless more than k duplicates of it have
    // smaller indices; the list is every other found point, at most k.
    int self_at = 0;
    while (self_at < found && ids[self_at] != self) ++self_at;
    const int before = std::min(self_at, k_);
    std::copy(ids, ids + before, dst);
    const int end = std::min(found, k_ + 1);
    int count = before;
    if (self_at + 1 < end) {
      std::copy(ids + self_at + 1, ids + end, dst + count);
      count += end - self_at - 1;
    }
    out_.counts[row] = static_cast<std::uint16_t>(count);
  }

  // The same from entries; `ids` has room for them.
  void write_row(std::size_t row, Index self, const Entry* best, int found, Index* ids) const {
    for (int j = 0; j < found; ++j) ids[j] = best[j].id;
    write_row(row, self, ids, found, found > 0 ? best[found - 1].d2 : 0.0);
  }

  const CellGrid& g_;
  const Queries& q_;
  int k_;
  int want_;
  double max_d2_;
  std::int64_t max_ring_;
  std::size_t budget_;
  double floor_d2_;  // the smallest threshold tried after 0 (duplicates)
  Neighborhoods& out_;
  std::span<double> last_d2_;
  std::vector<std::uint8_t>& unresolved_;
  KnnKernel kernel_;
};

// The rows of `q` into `out` (its arrays' storage reused).
void search(const CellGrid& g, const Queries& q, int k, double eps, const KdTree* tree,
            std::span<double> last_d2, Neighborhoods& out) {
  require(k >= 1 && k <= 1024, "k must be in 1..1024, got " + std::to_string(k));
  require(eps > 0.0, "eps must be positive");
  out.stride = k;
  out.eps = eps;
  // The lists are not advised for huge pages (the grid's arrays, read at random cells, are):
  // each row is written once and read whole, and a huge page's first touch cost more than its
  // TLB saves: on the 1M-point fandisk the neighbourhoods took 1.1-1.7 s with the k-48 lists
  // on huge pages and 0.6 s without, the steps the same (3 pairs alternating).
  out.indices.assign(q.size() * static_cast<std::size_t>(k), Index{0});
  out.counts.assign(q.size(), 0);
  std::vector<std::uint8_t> unresolved(q.size(), 0);
  require(last_d2.empty() || last_d2.size() == q.size(), "last_d2 must hold one value per row");
  const Search search(g, q, k, eps, out, last_d2, unresolved);
  // About 2048 queries a task.
  const std::size_t cells = q.cells();
  const std::size_t grain =
      std::max<std::size_t>(1, 2048 * cells / std::max<std::size_t>(1, q.size()));
  parallel_for(cells, [&](std::size_t b, std::size_t e) { search.run(b, e); }, grain);
  std::vector<Index> rest;
  for (std::size_t e = 0; e < unresolved.size(); ++e)
    if (unresolved[e] != 0) rest.push_back(static_cast<Index>(e));
  if (!rest.empty() && std::isfinite(g.cell)) {
    const Search wide(g, q, k, eps, out, last_d2, unresolved, true);
    parallel_for(rest.size(), [&](std::size_t b, std::size_t e) { wide.run_entries(rest, b, e); }, 16);
    std::erase_if(rest, [&](Index e) { return unresolved[e] == 0; });
  }
  search.fallback(rest, tree);
}

}  // namespace

Neighborhoods grid_neighborhoods(const CellGrid& grid, std::span<const Index> queries, int k,
                                 double eps, const KdTree* tree) {
  Neighborhoods out;
  grid_neighborhoods(grid, queries, k, eps, out, tree);
  return out;
}

void grid_neighborhoods(const CellGrid& grid, std::span<const Index> queries, int k, double eps,
                        Neighborhoods& out, const KdTree* tree) {
  search(grid, some_points(grid, queries), k, eps, tree, {}, out);
}

Neighborhoods grid_neighborhoods(const CellGrid& grid, int k, double eps,
                                 std::span<const Index> row_of, std::span<double> last_d2) {
  require(row_of.empty() || row_of.size() == grid.size(), "row_of must hold one row per point");
  Neighborhoods out;
  search(grid, every_point(grid, row_of), k, eps, nullptr, last_d2, out);
  return out;
}

}  // namespace pointfair
