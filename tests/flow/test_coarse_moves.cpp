// The coarse level's moves carried to every point: checked against the formula computed plainly
// (every anchor's distance, sorted by distance then index), to the bit, on clouds with exact
// ties (a lattice, duplicated anchors) where the search's own tie order would differ.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "pointfair/flow/coarse_moves.hpp"

namespace pointfair {
namespace {

std::vector<Vec3> reference_moves(std::vector<Vec3> positions, const std::vector<Vec3>& anchors,
                                  const std::vector<Vec3>& moved, int k) {
  for (Vec3& p : positions) {
    std::vector<std::pair<double, Index>> all;
    for (std::size_t a = 0; a < anchors.size(); ++a) {
      const double dx = p.x() - anchors[a].x(), dy = p.y() - anchors[a].y(), dz = p.z() - anchors[a].z();
      all.push_back({dx * dx + dy * dy + dz * dz, static_cast<Index>(a)});
    }
    std::sort(all.begin(), all.end());
    const std::size_t found = std::min<std::size_t>(static_cast<std::size_t>(k), all.size());
    const double reach2 = all[found - 1].first > 0.0 ? all[found - 1].first : 1.0;
    Vec3 move = Vec3::Zero();
    double weights = 0.0;
    for (std::size_t j = 0; j < found; ++j) {
      const double w = std::exp(-2.0 * all[j].first / reach2);
      move += w * (moved[all[j].second] - anchors[all[j].second]);
      weights += w;
    }
    p += move / weights;
  }
  return positions;
}

// Anchors on a lattice of unit spacing (every other one duplicated), the positions on the
// lattice and halfway between its points: most of their nearest anchors tie.
struct TiedCloud {
  std::vector<Vec3> positions, anchors, moved;
};

TiedCloud tied_cloud() {
  TiedCloud c;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  for (int x = 0; x < 9; ++x)
    for (int y = 0; y < 9; ++y)
      for (int z = 0; z < 3; ++z) {
        const Vec3 a(x, y, z);
        // Anchors listed in an order unlike their Morton order.
        const int copies = (x + y + z) % 2 == 0 ? 2 : 1;
        for (int j = 0; j < copies; ++j) {
          c.anchors.push_back(a);
          c.moved.push_back(a + Vec3(u(rng), u(rng), u(rng)));
        }
        c.positions.push_back(a);
        c.positions.push_back(a + Vec3(0.5, 0.5, 0.0));
        c.positions.push_back(a + Vec3(0.5, 0.0, 0.5));
      }
  std::reverse(c.anchors.begin(), c.anchors.end());
  std::reverse(c.moved.begin(), c.moved.end());
  return c;
}

TEST(CoarseMoves, MatchThePlainFormulaWithTies) {
  const TiedCloud c = tied_cloud();
  for (const int k : {1, 4, 8, 13}) {
    std::vector<Vec3> fast = c.positions;
    add_coarse_moves(fast, c.anchors, c.moved, k, morton_grid(c.positions));
    const std::vector<Vec3> plain = reference_moves(c.positions, c.anchors, c.moved, k);
    for (std::size_t i = 0; i < fast.size(); ++i) ASSERT_EQ(fast[i], plain[i]) << "k " << k << " point " << i;
  }
}

TEST(CoarseMoves, MatchThePlainFormulaOnANoisyCloud) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3> positions, anchors, moved;
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p(u(rng), u(rng), noise(rng));
    positions.push_back(p);
    if (i % 2 == 0) {
      anchors.push_back(p);
      moved.push_back(Vec3(p.x(), p.y(), 0.0));
    }
  }
  std::vector<Vec3> fast = positions;
  add_coarse_moves(fast, anchors, moved, 8, morton_grid(positions));
  EXPECT_EQ(fast, reference_moves(positions, anchors, moved, 8));
  // More anchors wanted than there are: every anchor takes part.
  std::vector<Vec3> few(positions.begin(), positions.begin() + 5);
  const std::vector<Vec3> few_anchors(anchors.begin(), anchors.begin() + 3),
      few_moved(moved.begin(), moved.begin() + 3);
  std::vector<Vec3> moved_few = few;
  add_coarse_moves(moved_few, few_anchors, few_moved, 8, morton_grid(few));
  EXPECT_EQ(moved_few, reference_moves(few, few_anchors, few_moved, 8));
}

TEST(CoarseMoves, AnAnchorAloneMovesEveryPointByItsMove) {
  std::vector<Vec3> positions{Vec3(0, 0, 0), Vec3(1, 2, 3)};
  add_coarse_moves(positions, std::vector<Vec3>{Vec3(0, 0, 0)}, std::vector<Vec3>{Vec3(0, 0, 0.5)}, 8,
                   morton_grid(positions));
  EXPECT_EQ(positions[0], Vec3(0, 0, 0.5));
  EXPECT_EQ(positions[1], Vec3(1, 2, 3.5));
}

}  // namespace
}  // namespace pointfair
