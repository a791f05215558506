// detail::select_kth against std::nth_element, its reference: the same value at every rank, on
// residual-like values, ties, a single distinct value, outliers far beyond the rest and the
// sizes around its bucket count.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "common/select_kth.hpp"

namespace pointfair {
namespace {

double reference_kth(std::vector<double> values, std::size_t k) {
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

void expect_every_rank(const std::vector<double>& values, const char* what) {
  std::vector<double> scratch(values.size());
  for (std::size_t k = 0; k < values.size(); ++k) {
    const double got = detail::select_kth(values, k, scratch);
    ASSERT_EQ(got, reference_kth(values, k)) << what << ", n " << values.size() << ", k " << k;
  }
}

TEST(SelectKth, MatchesNthElementAtEveryRank) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (const std::size_t n : {1u, 2u, 3u, 17u, 201u, 255u, 256u, 257u, 1025u}) {
    std::vector<double> residuals(n);
    for (double& r : residuals) r = std::abs(normal(rng));
    expect_every_rank(residuals, "half-normal");
    std::vector<double> signed_values(n);
    for (double& v : signed_values) v = normal(rng) * 1e-7 + 3.0;
    expect_every_rank(signed_values, "offset");
  }
}

TEST(SelectKth, TiesOutliersAndEqualValues) {
  std::vector<double> ties;
  for (int i = 0; i < 300; ++i) ties.push_back(static_cast<double>(i % 7) * 0.25);
  expect_every_rank(ties, "ties");
  std::vector<double> outliers(201, 0.0);
  for (std::size_t i = 0; i < outliers.size(); ++i) outliers[i] = 1e-9 * static_cast<double>(i);
  outliers[5] = 1e300;
  outliers[77] = 1e12;
  expect_every_rank(outliers, "outliers");
  expect_every_rank(std::vector<double>(50, 2.5), "equal");
  std::vector<double> with_zeros(100, 0.0);
  with_zeros[3] = 1.0;
  expect_every_rank(with_zeros, "zeros");
}

}  // namespace
}  // namespace pointfair
