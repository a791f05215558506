// SmoothParams::momentum: the heavy-ball steps. Checked against a plain loop of the formula
// (euler_step, the compensation, the momentum and its restarts), for the same bits on the
// double-buffered rows whatever the thread count, and by what it is for: heavy noise on a
// dense cloud gone in fewer steps, as far as without it.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/flow/euler_step.hpp"
#include "pointfair/flow/shrink_compensation.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "pointfair/smooth.hpp"
#include "support/checks.hpp"
#include "support/clouds.hpp"

namespace pointfair {
namespace {

// A unit sphere whose noise spans a few sample spacings (the case momentum is for).
std::vector<Vec3> heavy_noise_sphere(std::size_t n, std::uint64_t seed) {
  std::vector<Vec3> points = sample_sphere(n, 1.0, seed).points;
  add_noise(points, 0.015 * bounding_box_diagonal(points), seed + 1);
  return points;
}

TEST(Momentum, CompensatedRowsMatchThePlainFormulaAndMayOverwriteThePrevious) {
  const std::vector<Vec3> previous = heavy_noise_sphere(1500, 3);
  std::vector<Vec3> current = previous;
  add_noise(current, 0.002, 5);
  NeighborParams np;
  np.k = 12;
  const Neighborhoods nb = build_neighborhoods(current, np);
  FlowParams flow;
  std::vector<Vec3> updates(current.size());
  euler_step(current, nb, {}, flow, resolve_lambda(current, nb, flow), updates);
  to_updates(current, updates);
  const double m = 0.7;
  std::vector<Vec3> next(current.size());
  compensate_updates(current, updates, nb, {}, 1.0, StepMomentum{m, previous, {}}, next);
  double worst = 0.0;
  for (std::size_t i = 0; i < current.size(); ++i) {
    Vec3 sum = Vec3::Zero();
    for (const Index j : nb.of(i)) sum += updates[j];
    Vec3 step = updates[i] - sum / static_cast<double>(nb.of(i).size());
    if (step.norm() > updates[i].norm()) step = step.normalized() * updates[i].norm();
    const Vec3 expected = current[i] + step + m * (current[i] - previous[i]);
    worst = std::max(worst, (next[i] - expected).norm());
  }
  EXPECT_LT(worst, 1e-14);
  // The double-buffered steps keep the previous positions in the buffer they write.
  std::vector<Vec3> in_place = previous;
  compensate_updates(current, updates, nb, {}, 1.0, StepMomentum{m, in_place, {}}, in_place);
  EXPECT_TRUE(test::bitwise_equal(std::span<const Vec3>(in_place), std::span<const Vec3>(next)));
  // No momentum: the compensated step as before, to the bit.
  std::vector<Vec3> plain(current.size()), none(current.size());
  compensate_updates(current, updates, nb, {}, 1.0, plain);
  compensate_updates(current, updates, nb, {}, 1.0, StepMomentum{0.0, previous, {}}, none);
  EXPECT_TRUE(test::bitwise_equal(std::span<const Vec3>(plain), std::span<const Vec3>(none)));
  EXPECT_THROW(compensate_updates(current, updates, nb, {}, 1.0, StepMomentum{1.0, previous, {}}, none), ParamError);
}

TEST(Momentum, UncompensatedRowsAddTheMoveBefore) {
  const std::vector<Vec3> current = heavy_noise_sphere(200, 7), updated = heavy_noise_sphere(200, 9),
                          previous = heavy_noise_sphere(200, 11);
  std::vector<Vec3> next(current.size());
  add_momentum(current, updated, {}, StepMomentum{0.5, previous, {}}, next);
  for (std::size_t i = 0; i < next.size(); ++i)
    EXPECT_LT((next[i] - (updated[i] + 0.5 * (current[i] - previous[i]))).norm(), 1e-15);
  // Rows of other points (rows[r] is row r's point), the previous positions overwritten.
  const std::vector<Index> rows{5, 0, 17};
  std::vector<Vec3> some{previous[0], previous[1], previous[2]};
  const std::vector<Vec3> some_updated{updated[0], updated[1], updated[2]};
  add_momentum(current, some_updated, rows, StepMomentum{0.5, some, {}}, some);
  for (std::size_t r = 0; r < rows.size(); ++r)
    EXPECT_EQ(some[r], Vec3(some_updated[r] + 0.5 * (current[rows[r]] - previous[r])));
  add_momentum(current, updated, {}, StepMomentum{0.0, {}, {}}, next);
  EXPECT_TRUE(test::bitwise_equal(std::span<const Vec3>(next), std::span<const Vec3>(updated)));
}

TEST(Momentum, NoneOnTheFirstStepAfterARebuildWhereTheGaugeRoseOrInAGatedRun) {
  SmoothParams params;
  params.momentum = 0.6;
  const std::vector<double> slow{1.0, 0.95, 0.9}, fast{1.0, 0.6, 0.5};
  EXPECT_EQ(momentum_of_step(params, 0, false, false, std::span<const double>(slow).first(1)), 0.0);
  EXPECT_EQ(momentum_of_step(params, 1, false, false, std::span<const double>(slow).first(2)), 0.6);
  EXPECT_EQ(momentum_of_step(params, 2, false, false, slow), 0.6);
  EXPECT_EQ(momentum_of_step(params, 2, true, false, slow), 0.0);
  EXPECT_EQ(momentum_of_step(params, 2, false, true, slow), 0.0);
  // The first step left 0.6 of the gauge: a fast run, no momentum (the gate 0.9).
  EXPECT_EQ(momentum_of_step(params, 2, false, false, fast), 0.0);
  params.momentum_gate = 0.5;
  EXPECT_EQ(momentum_of_step(params, 2, false, false, fast), 0.6);
  // No gauge measured every step (the isotropic flow, a fixed lambda, a lambda measured once):
  // nothing for the gate to read, no momentum but with the gate off.
  params.momentum_gate = 0.9;
  EXPECT_EQ(momentum_of_step(params, 5, false, false, std::span<const double>(slow).first(1)), 0.0);
  SmoothParams isotropic = params, fixed = params, once = params;
  isotropic.flow.flow = Flow::Isotropic;
  fixed.flow.lambda = 12.0;
  once.lambda_every_step = false;
  for (SmoothParams* p : {&isotropic, &fixed, &once}) {
    EXPECT_EQ(momentum_of_step(*p, 2, false, false, slow), 0.0);
    p->momentum_gate = 0.0;
    EXPECT_EQ(momentum_of_step(*p, 2, false, false, std::span<const double>(slow).first(1)), 0.6);
  }
  params.momentum = 0.0;
  EXPECT_EQ(momentum_of_step(params, 5, false, false, slow), 0.0);
}

// Light noise loses most of its gauge in the first step: the gate leaves such a run without
// momentum, the same bits as without it.
TEST(Momentum, TheGateLeavesLightNoiseAlone) {
  std::vector<Vec3> input = sample_sphere(8000, 1.0, 23).points;
  add_noise(input, 0.001 * bounding_box_diagonal(input), 24);
  std::vector<Vec3> plain = input, gated = input, ungated = input;
  smooth(plain, {});
  SmoothParams params;
  params.momentum = 0.7;
  smooth(gated, params);
  EXPECT_TRUE(test::bitwise_equal(gated, plain));
  params.momentum_gate = 0.0;
  smooth(ungated, params);
  EXPECT_FALSE(test::bitwise_equal(ungated, plain));
}

// smooth() against a hand-driven loop of the same formula, restarts included: the same bits,
// compensated or not, with the lambda measured every step.
TEST(Momentum, SmoothIsTheHandDrivenLoop) {
  const std::vector<Vec3> input = test::noisy_cube(3000, 0.02, 4);
  for (const double beta : {1.0, 0.0}) {
    SmoothParams params;
    params.finish.reset();
    params.neighbors.k = 16;
    params.steps = 12;
    params.stop_lambda_ratio = 0.0;
    params.stop_plateau = 0.0;
    params.shrink_compensation = beta;
    params.momentum = 0.8;
    params.momentum_gate = 0.0;  // this light noise would turn it off (TheGateLeavesLightNoiseAlone)
    std::vector<Vec3> points = input;
    const SmoothReport report = smooth(points, params);

    const Neighborhoods n = build_neighborhoods(input, params.neighbors);
    std::vector<Vec3> current = input, previous = input, updated(input.size()), next(input.size());
    double lambda = resolve_lambda(current, n, params.flow);
    int restarts = 0;
    for (int s = 0; s < params.steps; ++s) {
      bool rose = false;
      if (s > 0) {
        const double measured = resolve_lambda(current, n, params.flow);
        rose = measured > lambda;
        lambda = measured;
      }
      const double m = s == 0 || rose ? 0.0 : params.momentum;
      restarts += s > 0 && rose ? 1 : 0;
      euler_step(current, n, {}, params.flow, lambda, updated);
      for (std::size_t i = 0; i < current.size(); ++i) updated[i] -= current[i];
      for (std::size_t i = 0; i < current.size(); ++i) {
        Vec3 step = updated[i];
        if (beta > 0.0) {
          Vec3 sum = Vec3::Zero();
          for (const Index j : n.of(i)) sum += updated[j];
          step = updated[i] - beta * (sum / static_cast<double>(n.of(i).size()));
          if (step.squaredNorm() > updated[i].squaredNorm()) step *= std::sqrt(updated[i].squaredNorm() / step.squaredNorm());
        }
        next[i] = m == 0.0 ? Vec3(current[i] + step) : Vec3((current[i] + step) + m * (current[i] - previous[i]));
      }
      previous = current;
      current.swap(next);
    }
    double worst = 0.0;
    for (std::size_t i = 0; i < input.size(); ++i) worst = std::max(worst, (points[i] - current[i]).norm());
    // The plain loop sums the neighbours' updates in one chain and the uncompensated step
    // through updated - current + current: equal up to rounding.
    EXPECT_LT(worst, 1e-12) << "beta " << beta;
    EXPECT_EQ(report.steps, params.steps);
    EXPECT_EQ(report.momentum_restarts, restarts) << "beta " << beta;
    EXPECT_GT(restarts, 0) << "beta " << beta;
  }
}

TEST(Momentum, BitIdenticalAcrossThreadCounts) {
  const std::vector<Vec3> input = heavy_noise_sphere(6000, 13);
  SmoothParams params;
  params.momentum = 0.7;
  std::vector<Vec3> one = input, two = input;
  set_thread_count(1);
  const SmoothReport a = smooth(one, params);
  set_thread_count(2);
  const SmoothReport b = smooth(two, params);
  set_thread_count(0);
  EXPECT_EQ(one, two);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.momentum_restarts, b.momentum_restarts);
}

// Heavy noise (a few sample spacings) on a sphere: the defaults with momentum stop in fewer
// than half the steps, as close to the sphere.
TEST(Momentum, HeavyNoiseGoesInFewerSteps) {
  const std::vector<Vec3> input = heavy_noise_sphere(30000, 17);
  std::vector<Vec3> plain = input, moving = input;
  SmoothParams params;
  params.finish.reset();  // the flow's own figures
  params.coarse.reset();  // the flow on every point from the start
  params.momentum = 0.0;
  const SmoothReport plain_report = smooth(plain, params);
  params.momentum = 0.7;
  const SmoothReport moving_report = smooth(moving, params);
  // Measured: 13 steps against 34, RMS 6.39e-3 against 6.53e-3 (input 51.6e-3).
  EXPECT_LT(moving_report.steps * 2, plain_report.steps) << plain_report.steps << " vs " << moving_report.steps;
  EXPECT_LT(test::unit_sphere_rms(moving), test::unit_sphere_rms(input) / 3.0);
  EXPECT_LE(test::unit_sphere_rms(moving), 1.02 * test::unit_sphere_rms(plain)) << test::unit_sphere_rms(plain);
}

TEST(Momentum, OutOfRangeIsRefused) {
  std::vector<Vec3> cloud = heavy_noise_sphere(500, 19);
  for (const double bad : {-0.1, 1.0, 1.5, std::nan("")}) {
    SmoothParams params;
    params.momentum = bad;
    EXPECT_THROW(smooth(cloud, params), ParamError) << bad;
  }
  for (const double bad : {-0.1, 1.01, std::nan("")}) {
    SmoothParams params;
    params.momentum = 0.5;
    params.momentum_gate = bad;
    EXPECT_THROW(smooth(cloud, params), ParamError) << bad;
  }
  EXPECT_EQ(paper_smooth_params().momentum, 0.0);
}

}  // namespace
}  // namespace pointfair
