// rank_sort against a plain std::sort by (squared distance, index) on seeded random candidates:
// distinct distances, many ties and duplicates, zeros and +infinity, every count up to
// kRankSortMax, on the plain kernel and (where the CPU has it) the AVX2 kernel.
#include "pointfair/neighbors/knn_select.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace pointfair {
namespace {

struct Case {
  std::vector<double> d2;
  std::vector<Index> id;
};

// n candidates with distinct random indices; `levels` distinct distances (0: all distinct).
Case random_case(std::size_t n, int levels, std::mt19937_64& rng) {
  Case c;
  std::uniform_real_distribution<double> any(0.0, 4.0);
  std::uniform_int_distribution<int> level(0, std::max(levels - 1, 0));
  for (std::size_t i = 0; i < n; ++i) c.d2.push_back(levels == 0 ? any(rng) : 0.25 * level(rng));
  std::vector<Index> pool(3 * n + 1);
  std::iota(pool.begin(), pool.end(), Index{1000});
  std::shuffle(pool.begin(), pool.end(), rng);
  c.id.assign(pool.begin(), pool.begin() + static_cast<std::ptrdiff_t>(n));
  return c;
}

std::vector<std::pair<double, Index>> reference(const Case& c) {
  std::vector<std::pair<double, Index>> r;
  for (std::size_t i = 0; i < c.d2.size(); ++i) r.emplace_back(c.d2[i], c.id[i]);
  std::sort(r.begin(), r.end());
  return r;
}

std::vector<std::pair<double, Index>> ranked(const Case& c, KnnKernel kernel) {
  const std::size_t n = c.d2.size();
  std::vector<double> d2(n + 4, -1.0);  // room for the padding
  std::copy(c.d2.begin(), c.d2.end(), d2.begin());
  std::vector<double> out_d2(n, -1.0);
  std::vector<Index> out_id(n, 0);
  rank_sort(d2.data(), c.id.data(), n, out_d2.data(), out_id.data(), kernel);
  std::vector<std::pair<double, Index>> r;
  for (std::size_t i = 0; i < n; ++i) r.emplace_back(out_d2[i], out_id[i]);
  return r;
}

std::vector<KnnKernel> kernels() {
  std::vector<KnnKernel> k = {KnnKernel::Plain};
  if (knn_kernel_available(KnnKernel::Avx2)) k.push_back(KnnKernel::Avx2);
  return k;
}

TEST(KnnSelect, RankSortMatchesStdSortWithTiesAndDuplicates) {
  std::mt19937_64 rng(2024);
  for (const KnnKernel kernel : kernels()) {
    for (const int levels : {0, 1, 2, 3, 7, 40}) {
      for (std::size_t n = 0; n <= kRankSortMax; ++n) {
        for (int rep = 0; rep < 4; ++rep) {
          const Case c = random_case(n, levels, rng);
          ASSERT_EQ(ranked(c, kernel), reference(c))
              << "n " << n << ", levels " << levels << ", kernel " << static_cast<int>(kernel);
        }
      }
    }
  }
}

TEST(KnnSelect, RankSortZerosInfinityAndExtremeIndices) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  constexpr Index kLast = std::numeric_limits<Index>::max() - 1;  // the largest allowed
  const Case c = {{kInf, 0.0, 1e-300, kInf, 0.0, 5e-324, 1e300, 0.0, 1.0},
                  {7, kLast, 3, 0, 2, 9, 4, 1, 8}};
  for (const KnnKernel kernel : kernels()) EXPECT_EQ(ranked(c, kernel), reference(c));
  const auto r = ranked(c, KnnKernel::Plain);
  EXPECT_EQ(r.front(), std::make_pair(0.0, Index{1}));
  EXPECT_EQ(r.back(), std::make_pair(kInf, Index{7}));
}

TEST(KnnSelect, KernelChoiceFollowsTheCpuAndTheEnvironment) {
  // ctest runs the neighbourhood tests once more with POINTFAIR_NO_AVX2=1.
  const char* off = std::getenv("POINTFAIR_NO_AVX2");
  const bool disabled = off != nullptr && off[0] != '\0' && std::string(off) != "0";
  const KnnKernel expected =
      !disabled && knn_kernel_available(KnnKernel::Avx2) ? KnnKernel::Avx2 : KnnKernel::Plain;
  EXPECT_EQ(default_knn_kernel(), expected);
  EXPECT_TRUE(knn_kernel_available(KnnKernel::Plain));
}

}  // namespace
}  // namespace pointfair
