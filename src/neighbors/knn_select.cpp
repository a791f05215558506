#include "pointfair/neighbors/knn_select.hpp"

#include <cstdint>
#include <cstdlib>
#include <limits>
#include <string_view>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define POINTFAIR_KNN_SELECT_AVX2 1
#include <immintrin.h>
#endif

namespace pointfair {
namespace {

constexpr Index kFree = std::numeric_limits<Index>::max();

// ranks[i] = how many of d2[0..n) are < d2[i], for i < n (ranks has room for n rounded up to
// a multiple of 4; d2 is padded to it with zeros, whose ranks are 0). Returns the sum of the
// ranks: n (n - 1) / 2 exactly when no two distances are equal.
std::int64_t count_closer_plain(const double* d2, std::size_t n, std::int64_t* ranks) {
  std::int64_t sum = 0;
  std::size_t i = 0;
#if defined(__SSE2__)
  // Two candidates a lane pair: each other candidate broadcast and compared with both.
  for (; i + 2 <= n; i += 2) {
    const __m128d di = _mm_loadu_pd(d2 + i);
    __m128i acc = _mm_setzero_si128();
    for (std::size_t j = 0; j < n; ++j)
      acc = _mm_sub_epi64(acc, _mm_castpd_si128(_mm_cmplt_pd(_mm_set1_pd(d2[j]), di)));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(ranks + i), acc);
    sum += ranks[i] + ranks[i + 1];
  }
#endif
  for (; i < n; ++i) {
    std::int64_t r = 0;
    for (std::size_t j = 0; j < n; ++j) r += d2[j] < d2[i] ? 1 : 0;
    ranks[i] = r;
    sum += r;
  }
  return sum;
}

#if defined(POINTFAIR_KNN_SELECT_AVX2)
// As count_closer_plain, sixteen or eight candidates at a time (lanes of four).
__attribute__((target("avx2"))) std::int64_t count_closer_avx2(const double* d2, std::size_t n,
                                                               std::int64_t* ranks) {
  __m256i total = _mm256_setzero_si256();
  std::size_t i = 0;
  for (; i + 12 < n; i += 16) {
    const __m256d a = _mm256_loadu_pd(d2 + i), b = _mm256_loadu_pd(d2 + i + 4);
    const __m256d c = _mm256_loadu_pd(d2 + i + 8), d = _mm256_loadu_pd(d2 + i + 12);
    __m256i ra = _mm256_setzero_si256(), rb = _mm256_setzero_si256();
    __m256i rc = _mm256_setzero_si256(), rd = _mm256_setzero_si256();
    for (std::size_t j = 0; j < n; ++j) {
      const __m256d dj = _mm256_broadcast_sd(d2 + j);
      ra = _mm256_sub_epi64(ra, _mm256_castpd_si256(_mm256_cmp_pd(dj, a, _CMP_LT_OQ)));
      rb = _mm256_sub_epi64(rb, _mm256_castpd_si256(_mm256_cmp_pd(dj, b, _CMP_LT_OQ)));
      rc = _mm256_sub_epi64(rc, _mm256_castpd_si256(_mm256_cmp_pd(dj, c, _CMP_LT_OQ)));
      rd = _mm256_sub_epi64(rd, _mm256_castpd_si256(_mm256_cmp_pd(dj, d, _CMP_LT_OQ)));
    }
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(ranks + i), ra);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(ranks + i + 4), rb);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(ranks + i + 8), rc);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(ranks + i + 12), rd);
    total = _mm256_add_epi64(total, _mm256_add_epi64(_mm256_add_epi64(ra, rb), _mm256_add_epi64(rc, rd)));
  }
  for (; i + 4 < n; i += 8) {
    const __m256d a = _mm256_loadu_pd(d2 + i), b = _mm256_loadu_pd(d2 + i + 4);
    __m256i ra = _mm256_setzero_si256(), rb = _mm256_setzero_si256();
    for (std::size_t j = 0; j < n; ++j) {
      const __m256d dj = _mm256_broadcast_sd(d2 + j);
      ra = _mm256_sub_epi64(ra, _mm256_castpd_si256(_mm256_cmp_pd(dj, a, _CMP_LT_OQ)));
      rb = _mm256_sub_epi64(rb, _mm256_castpd_si256(_mm256_cmp_pd(dj, b, _CMP_LT_OQ)));
    }
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(ranks + i), ra);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(ranks + i + 4), rb);
    total = _mm256_add_epi64(total, _mm256_add_epi64(ra, rb));
  }
  for (; i < n; i += 4) {
    const __m256d a = _mm256_loadu_pd(d2 + i);
    __m256i ra = _mm256_setzero_si256();
    for (std::size_t j = 0; j < n; ++j)
      ra = _mm256_sub_epi64(ra, _mm256_castpd_si256(_mm256_cmp_pd(_mm256_broadcast_sd(d2 + j), a, _CMP_LT_OQ)));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(ranks + i), ra);
    total = _mm256_add_epi64(total, ra);
  }
  const __m128i half = _mm_add_epi64(_mm256_castsi256_si128(total), _mm256_extracti128_si256(total, 1));
  return _mm_cvtsi128_si64(_mm_add_epi64(half, _mm_unpackhi_epi64(half, half)));
}

bool cpu_has_avx2() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") != 0;
}
#endif

bool avx2_disabled_by_environment() {
  const char* value = std::getenv("POINTFAIR_NO_AVX2");
  return value != nullptr && value[0] != '\0' && std::string_view(value) != "0";
}

}  // namespace

bool knn_kernel_available(KnnKernel kernel) {
#if defined(POINTFAIR_KNN_SELECT_AVX2)
  static const bool has_avx2 = cpu_has_avx2();
#else
  constexpr bool has_avx2 = false;
#endif
  return kernel == KnnKernel::Plain || has_avx2;
}

KnnKernel default_knn_kernel() {
  static const KnnKernel kernel = !avx2_disabled_by_environment() && knn_kernel_available(KnnKernel::Avx2)
                                      ? KnnKernel::Avx2
                                      : KnnKernel::Plain;
  return kernel;
}

void rank_sort(double* d2, const Index* id, std::size_t n, double* out_d2, Index* out_id,
               KnnKernel kernel) {
  // Eight more than the most candidates: the AVX2 scan reads whole groups of four or eight.
  std::int64_t ranks[kRankSortMax + 8];
  const std::size_t padded = (n + 3) & ~std::size_t{3};
  for (std::size_t i = n; i < padded; ++i) d2[i] = 0.0;  // ranks of padding are not used
  std::int64_t sum = 0;
#if defined(POINTFAIR_KNN_SELECT_AVX2)
  if (kernel == KnnKernel::Avx2 && knn_kernel_available(KnnKernel::Avx2))
    sum = count_closer_avx2(d2, n, ranks);
  else
    sum = count_closer_plain(d2, n, ranks);
#else
  (void)kernel;
  sum = count_closer_plain(d2, n, ranks);
#endif
  if (sum == static_cast<std::int64_t>(n * (n - 1) / 2)) {
    // No ties (they would share a rank and lower the sum): the ranks are the places.
    for (std::size_t i = 0; i < n; ++i) {
      const auto r = static_cast<std::size_t>(ranks[i]);
      out_d2[r] = d2[i];
      out_id[r] = id[i];
    }
    return;
  }
  for (std::size_t r = 0; r < n; ++r) out_id[r] = kFree;
  // Equal distances share a rank: each takes the next free place after it.
  for (std::size_t i = 0; i < n; ++i) {
    auto r = static_cast<std::size_t>(ranks[i]);
    while (out_id[r] != kFree) ++r;
    out_d2[r] = d2[i];
    out_id[r] = id[i];
  }
  // Runs of ties, in the order found: sort each by index.
  for (std::size_t r = 1; r < n; ++r) {
    if (out_d2[r] != out_d2[r - 1]) continue;
    const Index v = out_id[r];
    std::size_t p = r;
    while (p > 0 && out_d2[p - 1] == out_d2[r] && out_id[p - 1] > v) {
      out_id[p] = out_id[p - 1];
      --p;
    }
    out_id[p] = v;
  }
}

}  // namespace pointfair
