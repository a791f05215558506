#include "pointfair/eval/aabb_tree.hpp"

#include <random>

#include <gtest/gtest.h>

namespace pointfair::eval {
namespace {

TEST(AabbTree, NearestSphereCentreMatchesBruteForce) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3> centres(500);
  std::vector<Eigen::AlignedBox3d> boxes;
  const double r = 0.01;
  for (auto& c : centres) {
    c = Vec3(u(rng), u(rng), u(rng));
    boxes.emplace_back(c - Vec3::Constant(r), c + Vec3::Constant(r));
  }
  const AabbTree tree(boxes);
  for (int q = 0; q < 200; ++q) {
    const Vec3 p(2 * u(rng), 2 * u(rng), 2 * u(rng));
    auto d2 = [&](Index i) {
      const double d = std::max(0.0, (p - centres[i]).norm() - r);
      return d * d;
    };
    Index brute = 0;
    for (Index i = 1; i < centres.size(); ++i)
      if (d2(i) < d2(brute)) brute = i;
    const auto [found, found_d2] = tree.nearest(p, d2);
    EXPECT_EQ(found, brute);
    EXPECT_DOUBLE_EQ(found_d2, d2(brute));
  }
}

TEST(AabbTree, EmptyTreeFindsNothing) {
  const AabbTree tree;
  const auto [found, d2] = tree.nearest(Vec3::Zero(), [](Index) { return 0.0; });
  EXPECT_EQ(found, std::numeric_limits<Index>::max());
  EXPECT_TRUE(std::isinf(d2));
}

}  // namespace
}  // namespace pointfair::eval
