// Shrinkage compensation (shrink_compensation.hpp) and the plateau stop of smooth(): checked
// against a plain loop of the formula, and by what they are for: a sphere that keeps its
// radius while its noise goes, and a stop that ends a run whose lambda no longer falls.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/flow/euler_step.hpp"
#include "pointfair/flow/shrink_compensation.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "pointfair/smooth.hpp"
#include "support/checks.hpp"

namespace pointfair {
namespace {

std::vector<Vec3> noisy_sphere(std::size_t n, double sigma, std::uint64_t seed) {
  std::vector<Vec3> p = sample_sphere(n, 1.0, seed).points;
  add_noise(p, sigma, seed + 1);
  return p;
}

double mean_radius(const std::vector<Vec3>& p) {
  double s = 0.0;
  for (const Vec3& x : p) s += x.norm();
  return s / static_cast<double>(p.size());
}

TEST(ShrinkCompensation, MatchesThePlainFormula) {
  const std::vector<Vec3> current = noisy_sphere(2000, 0.01, 3);
  NeighborParams np;
  np.k = 12;
  const Neighborhoods nb = build_neighborhoods(current, np);
  FlowParams flow;
  std::vector<Vec3> updated(current.size());
  euler_step(current, nb, {}, flow, resolve_lambda(current, nb, flow), updated);
  for (const double beta : {0.0, 0.5, 1.0}) {
    std::vector<Vec3> next(current.size());
    compensate_shrinkage(current, updated, nb, {}, beta, next);
    double worst = 0.0;
    for (std::size_t i = 0; i < current.size(); ++i) {
      Vec3 sum = Vec3::Zero();
      const auto row = nb.of(i);
      for (std::size_t a = 0; a < row.size(); ++a) sum += updated[row[a]] - current[row[a]];
      const Vec3 own = updated[i] - current[i];
      Vec3 step = own - beta * sum / static_cast<double>(row.size());
      if (step.norm() > own.norm()) step = step.normalized() * own.norm();
      const Vec3 expected = current[i] + step;
      worst = std::max(worst, (next[i] - expected).norm());
    }
    EXPECT_LT(worst, 1e-14) << "beta " << beta;
    if (beta == 0.0) {
      EXPECT_TRUE(test::bitwise_equal(std::span<const Vec3>(next), std::span<const Vec3>(updated)));
    }
  }
}

// Two points pull toward each other; their updates alternate in sign. Uncapped, tau 0.8 and
// beta 1 would multiply their distance by 1 - 2 x 0.8 x 2 = -2.2 per step; capped at the
// flow's own update it is 1 - 2 x 0.8 = -0.6.
TEST(ShrinkCompensation, AlternatingUpdatesAreCappedAndTwoPointsConverge) {
  const std::vector<Vec3> current = {Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0)};
  Neighborhoods nb;
  nb.stride = 1;
  nb.counts = {1, 1};
  nb.indices = {1, 0};
  const std::vector<Vec3> updated = {Vec3(0.8, 0.0, 0.0), Vec3(0.2, 0.0, 0.0)};
  std::vector<Vec3> next(2);
  compensate_shrinkage(current, updated, nb, {}, 1.0, next);
  EXPECT_NEAR((next[1] - next[0]).x(), -0.6, 1e-15);
  EXPECT_EQ(next[0], updated[0]);  // the cap: the flow's own update, no farther
  // And the whole compensated isotropic flow on them: their distance shrinks every step.
  SmoothParams params;
  params.finish.reset();  // the flow alone
  params.flow.flow = Flow::Isotropic;
  params.flow.tau = 0.8;
  params.shrink_compensation = 1.0;
  params.neighbors.k = 1;
  params.neighbors.eps = std::numeric_limits<double>::infinity();
  double distance = 1.0;
  for (const int steps : {1, 2, 5, 20}) {
    std::vector<Vec3> points = current;
    params.steps = steps;
    smooth(points, params);
    const double d = (points[1] - points[0]).norm();
    EXPECT_LT(d, distance) << steps << " steps";
    EXPECT_TRUE(std::isfinite(d));
    distance = d;
  }
}

TEST(ShrinkCompensation, RowsSelectThePointsAndTheResultIsTheSameForAnyThreadCount) {
  const std::vector<Vec3> current = noisy_sphere(3000, 0.01, 5);
  NeighborParams np;
  np.k = 10;
  const Neighborhoods nb = build_neighborhoods(current, np);
  std::vector<Vec3> updated(current.size());
  euler_step(current, nb, {}, FlowParams{}, 30.0, updated);
  std::vector<Vec3> all(current.size());
  compensate_shrinkage(current, updated, nb, {}, 1.0, all);
  // The rows of every third point, with their neighbour lists: the same values.
  Neighborhoods some;
  some.stride = nb.stride;
  std::vector<Index> rows;
  for (std::size_t i = 0; i < current.size(); i += 3) {
    rows.push_back(static_cast<Index>(i));
    const auto row = nb.of(i);
    some.indices.insert(some.indices.end(), nb.indices.begin() + static_cast<std::ptrdiff_t>(i * static_cast<std::size_t>(nb.stride)),
                        nb.indices.begin() + static_cast<std::ptrdiff_t>((i + 1) * static_cast<std::size_t>(nb.stride)));
    some.counts.push_back(static_cast<std::uint16_t>(row.size()));
  }
  std::vector<Vec3> part(rows.size());
  compensate_shrinkage(current, updated, some, rows, 1.0, part);
  for (std::size_t r = 0; r < rows.size(); ++r) EXPECT_EQ(part[r], all[rows[r]]);
  set_thread_count(1);
  std::vector<Vec3> one(current.size());
  compensate_shrinkage(current, updated, nb, {}, 1.0, one);
  set_thread_count(0);
  EXPECT_TRUE(test::bitwise_equal(std::span<const Vec3>(one), std::span<const Vec3>(all)));
}

// The production path (to_updates, then compensate_updates: one array read a neighbour)
// against compensate_shrinkage, which subtracts the positions itself: the same bits, for
// every row and for rows of some points.
TEST(ShrinkCompensation, UpdatesGiveThePositionsBits) {
  const std::vector<Vec3> current = noisy_sphere(3000, 0.01, 6);
  NeighborParams np;
  np.k = 12;
  const Neighborhoods nb = build_neighborhoods(current, np);
  std::vector<Vec3> updated(current.size());
  euler_step(current, nb, {}, FlowParams{}, 30.0, updated);
  for (const double beta : {0.5, 1.0}) {
    std::vector<Vec3> reference(current.size()), fast(current.size());
    compensate_shrinkage(current, updated, nb, {}, beta, reference);
    std::vector<Vec3> updates = updated;
    to_updates(current, updates);
    compensate_updates(current, updates, nb, {}, beta, fast);
    EXPECT_TRUE(test::bitwise_equal(std::span<const Vec3>(fast), std::span<const Vec3>(reference))) << beta;
    EXPECT_NE(fast, updated);  // compensated: not the plain step
  }
}

TEST(ShrinkCompensation, RejectsBetaOutsideTheUnitInterval) {
  SmoothParams p;
  p.finish.reset();  // the flow alone
  p.shrink_compensation = 1.5;
  EXPECT_THROW(p.validate(), ParamError);
  p.shrink_compensation = -0.1;
  EXPECT_THROW(p.validate(), ParamError);
  p.shrink_compensation = 1.0;
  p.stop_plateau = 1.0;
  EXPECT_THROW(p.validate(), ParamError);
}

SmoothParams sphere_params(double beta) {
  SmoothParams p;
  p.finish.reset();  // the flow alone
  p.neighbors.k = 16;
  p.flow.flow = Flow::Isotropic;
  p.steps = 20;
  p.stop_lambda_ratio = 0.0;
  p.shrink_compensation = beta;
  return p;
}

TEST(ShrinkCompensation, KeepsTheSphereItsSizeWhileRemovingItsNoise) {
  const std::vector<Vec3> input = noisy_sphere(4000, 0.01, 11);
  std::vector<Vec3> plain = input;
  smooth(plain, sphere_params(0.0));
  std::vector<Vec3> compensated = input;
  smooth(compensated, sphere_params(1.0));
  const double shrink_plain = 1.0 - mean_radius(plain);
  const double shrink_compensated = std::abs(1.0 - mean_radius(compensated));
  // The umbrella flow shrinks the unit sphere by a few percent in 20 steps; compensated, by
  // a small fraction of that.
  EXPECT_GT(shrink_plain, 0.01);
  EXPECT_LT(shrink_compensated, 0.1 * shrink_plain);
  // And the noise is still removed: the radial error falls well below the input's.
  EXPECT_LT(test::unit_sphere_rms(compensated), 0.5 * test::unit_sphere_rms(input));
  EXPECT_LT(test::unit_sphere_rms(compensated), test::unit_sphere_rms(plain));
}

TEST(StopPlateau, StopsOnceLambdaNoLongerFalls) {
  SmoothParams p;
  p.finish.reset();  // the flow alone
  p.stop_lambda_ratio = 0.0;
  p.stop_plateau = 0.03;
  // Falling by 10% a step: never a plateau.
  std::vector<double> falling{1.0};
  for (int s = 1; s <= 20; ++s) falling.push_back(falling.back() * 0.9);
  for (std::size_t n = 1; n <= falling.size(); ++n)
    EXPECT_FALSE(should_stop(p, std::span<const double>(falling.data(), n))) << n;
  // Flat after a fall to 0.25: the plateau is only looked for from 8 steps on.
  std::vector<double> flat(12, 0.25);
  flat[0] = 1.0;
  for (std::size_t n = 1; n <= 8; ++n) EXPECT_FALSE(should_stop(p, std::span<const double>(flat.data(), n))) << n;
  EXPECT_TRUE(should_stop(p, std::span<const double>(flat.data(), 9)));
  // Flat before lambda has fallen to 0.7 of the input's: the noise is still there.
  flat[0] = 0.3;
  EXPECT_FALSE(should_stop(p, std::span<const double>(flat.data(), 9)));
  // A fall of 3.5% over 4 steps does not stop; 2.5% does.
  std::vector<double> l(9, 0.2);
  l[0] = 1.0;
  l[8] = 0.2 * 0.965;
  EXPECT_FALSE(should_stop(p, l));
  l[8] = 0.2 * 0.975;
  EXPECT_TRUE(should_stop(p, l));
  p.stop_plateau = 0.0;
  EXPECT_FALSE(should_stop(p, l));
  // The ratio stop alone.
  p.stop_lambda_ratio = 0.5;
  EXPECT_FALSE(should_stop(p, std::vector<double>{1.0, 0.6}));
  EXPECT_TRUE(should_stop(p, std::vector<double>{1.0, 0.5}));
}

TEST(StopPlateau, EndsACompensatedRunOnACurvedSurfaceEarly) {
  const std::vector<Vec3> input = noisy_sphere(3000, 0.03, 13);
  SmoothParams p;
  p.finish.reset();  // the flow alone
  p.neighbors.k = 16;
  p.steps = 200;
  p.stop_lambda_ratio = 0.0;
  p.stop_plateau = 0.03;
  p.shrink_compensation = 1.0;
  std::vector<Vec3> out = input;
  const SmoothReport r = smooth(out, p);
  EXPECT_TRUE(r.stopped_early);
  EXPECT_GE(r.steps, 8);
  EXPECT_LT(r.steps, 200);
  // The same number of steps without the stop gives the same cloud.
  SmoothParams fixed = p;
  fixed.stop_plateau = 0.0;
  fixed.steps = r.steps;
  std::vector<Vec3> same = input;
  smooth(same, fixed);
  EXPECT_TRUE(test::bitwise_equal(std::span<const Vec3>(same), std::span<const Vec3>(out)));
}

}  // namespace
}  // namespace pointfair
