// Options beyond the literal method that the defaults use: the cut-off's curvatures measured
// from the point's foot on its PCA plane (CutoffOrigin::Plane), and the automatic stop of the
// anisotropic flow when the automatic lambda has fallen to a fraction of its input value
// (SmoothParams::stop_lambda_ratio). The paper's behaviour stays reachable (Point, 0).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "pointfair/common/params_error.hpp"
#include "pointfair/flow/euler_step.hpp"
#include "pointfair/smooth.hpp"
#include "support/checks.hpp"
#include "support/clouds.hpp"

namespace pointfair {
namespace {

// A ring of m points of radius r in the plane z = 0 around point 0, which is lifted to
// height h (noise). Its PCA normal is z; from the point, every neighbour has
// |kappa| = 2 h / (r^2 + h^2); from its foot on the PCA plane (height h / (m + 1)),
// |kappa| = 2 (h / (m + 1)) / (r^2 + (h / (m + 1))^2).
struct LiftedRing {
  std::vector<Vec3> points;
  std::vector<Index> neighbors;
};

LiftedRing lifted_ring(int m, double r, double h) {
  LiftedRing c;
  c.points.emplace_back(0.0, 0.0, h);
  for (int j = 0; j < m; ++j) {
    const double a = 2.0 * std::numbers::pi * (j + 0.25) / m;
    c.points.emplace_back(r * std::cos(a), r * std::sin(a), 0.0);
    c.neighbors.push_back(static_cast<Index>(j + 1));
  }
  return c;
}

TEST(CutoffOrigin, PlaneOriginLetsALiftedPointReturnWhereThePointOriginHoldsItUp) {
  const int m = 12;
  const double r = 1.0, h = 0.2;
  const LiftedRing c = lifted_ring(m, r, h);
  // Between the two |kappa|: from the point every neighbour is cut off, from the foot none.
  const double lambda = 0.2;
  ASSERT_GT(2.0 * h / (r * r + h * h), lambda);
  ASSERT_LT(2.0 * h / (m + 1) / (r * r), lambda);
  FlowParams params;
  params.tau = 0.5;
  params.cutoff = Cutoff::Sharp;
  params.cutoff_origin = CutoffOrigin::Point;
  const PointState at_point = evaluate_point(c.points[0], c.neighbors, c.points, params, lambda, false);
  ASSERT_TRUE(at_point.valid);
  EXPECT_EQ(at_point.displacement, Vec3::Zero()) << "the paper: a lifted point stays lifted";
  params.cutoff_origin = CutoffOrigin::Plane;
  const PointState at_plane = evaluate_point(c.points[0], c.neighbors, c.points, params, lambda, false);
  ASSERT_TRUE(at_plane.valid);
  // All neighbours kept: A = mean of (p_j - p_0) = (0, 0, -h); the step is tau A.
  EXPECT_NEAR(at_plane.displacement.z(), -params.tau * h, 1e-12);
  EXPECT_NEAR(at_plane.displacement.head<2>().norm(), 0.0, 1e-12);

  // The Euler step's own (fast) path agrees: one neighbourhood row, for point 0.
  Neighborhoods one;
  one.stride = m;
  one.indices = c.neighbors;
  one.counts = {static_cast<std::uint16_t>(m)};
  std::vector<Vec3> out(1);
  euler_step(c.points, one, std::vector<Index>{0}, params, lambda, out);
  EXPECT_NEAR((out[0] - (c.points[0] + at_plane.displacement)).norm(), 0.0, 1e-12);
  params.cutoff_origin = CutoffOrigin::Point;
  euler_step(c.points, one, std::vector<Index>{0}, params, lambda, out);
  EXPECT_EQ(out[0], c.points[0]);
}

TEST(CutoffOrigin, PlaneOriginIsFreeOfTheNormalSign) {
  const std::vector<Vec3> points = test::noisy_cube(1500, 0.01, 5);
  NeighborParams np;
  np.k = 16;
  const Neighborhoods n = build_neighborhoods(points, np);
  for (std::size_t i = 0; i < points.size(); i += 37) {
    const Frame f = compute_frame(points[i], n.of(i), points);
    if (!f.valid) continue;
    const double height = f.normal.dot(f.centroid - points[i]);
    const LaplacianParams up{Flow::Anisotropic, Cutoff::Sharp, 30.0, height};
    const LaplacianParams down{Flow::Anisotropic, Cutoff::Sharp, 30.0, -height};
    EXPECT_EQ(laplacian(points[i], f.normal, n.of(i), points, up),
              laplacian(points[i], -f.normal, n.of(i), points, down)) << i;
  }
}

SmoothParams stop_params(double ratio, int steps) {
  SmoothParams p;
  p.finish.reset();  // the flow alone
  p.neighbors.k = 16;
  p.steps = steps;
  p.stop_lambda_ratio = ratio;
  p.stop_plateau = 0.0;  // the ratio stop alone
  return p;
}

TEST(StopLambdaRatio, StopsOnceLambdaFellAndEqualsARunOfThatManySteps) {
  const std::vector<Vec3> input = test::noisy_cube(3000, 0.01, 7);
  std::vector<Vec3> stopped = input;
  const SmoothReport r = smooth(stopped, stop_params(0.5, 60));
  EXPECT_TRUE(r.stopped_early);
  EXPECT_GT(r.steps, 0);
  EXPECT_LT(r.steps, 60);
  std::vector<Vec3> unmoved = input;
  EXPECT_LE(r.lambda, 0.5 * smooth(unmoved, stop_params(0.0, 0)).lambda);
  // The same as running exactly that many steps without the stop, bit for bit.
  std::vector<Vec3> fixed = input;
  const SmoothReport f = smooth(fixed, stop_params(0.0, r.steps));
  EXPECT_FALSE(f.stopped_early);
  EXPECT_EQ(f.steps, r.steps);
  EXPECT_TRUE(test::bitwise_equal(stopped, fixed));
}

TEST(StopLambdaRatio, OffForTheIsotropicFlowAFixedLambdaOrZero) {
  const std::vector<Vec3> input = test::noisy_cube(2000, 0.01, 9);
  SmoothParams iso = stop_params(0.9, 12);
  iso.flow.flow = Flow::Isotropic;
  SmoothParams fixed_lambda = stop_params(0.9, 12);
  fixed_lambda.flow.lambda = 25.0;
  SmoothParams once = stop_params(0.9, 12);
  once.lambda_every_step = false;
  for (const SmoothParams& p : {iso, fixed_lambda, once, stop_params(0.0, 12)}) {
    std::vector<Vec3> points = input;
    const SmoothReport r = smooth(points, p);
    EXPECT_EQ(r.steps, 12);
    EXPECT_FALSE(r.stopped_early);
  }
  // A ratio this close to 1 stops the default (anisotropic, every-step) flow at once.
  std::vector<Vec3> points = input;
  EXPECT_LT(smooth(points, stop_params(0.9, 12)).steps, 12);
}

TEST(StopLambdaRatio, RejectsRatiosOutsideZeroToOne) {
  EXPECT_THROW(stop_params(1.0, 5).validate(), ParamError);
  EXPECT_THROW(stop_params(-0.1, 5).validate(), ParamError);
  EXPECT_THROW(stop_params(std::nan(""), 5).validate(), ParamError);
  EXPECT_NO_THROW(stop_params(0.0, 5).validate());
}

// --paper: the paper's reading on top of the caller's other settings.
TEST(PaperParams, ThePaperStepCountAndNoStopOrCompensationOnTopOfTheBase) {
  SmoothParams base;
  base.finish.reset();  // the flow alone
  base.neighbors.k = 24;
  base.flow.lambda = 3.0;
  const SmoothParams p = paper_smooth_params(base);
  EXPECT_EQ(p.flow.cutoff_origin, CutoffOrigin::Point);
  EXPECT_EQ(p.flow.normal_estimator, NormalEstimator::Pca);
  EXPECT_EQ(p.flow.tau, 0.5);
  EXPECT_EQ(p.steps, 100);
  EXPECT_EQ(p.stop_lambda_ratio, 0.0);
  EXPECT_EQ(p.stop_plateau, 0.0);
  EXPECT_EQ(p.shrink_compensation, 0.0);
  EXPECT_EQ(p.neighbors.k, 24);
  EXPECT_EQ(p.flow.lambda, 3.0);
  // The paper's flow step is FlowParams{}'s, but for what the base chose.
  const FlowParams paper_step;
  EXPECT_EQ(p.flow.tau, paper_step.tau);
  EXPECT_EQ(p.flow.cutoff_origin, paper_step.cutoff_origin);
  // Defaults differ from it where the quality bench chose otherwise.
  const SmoothParams d;
  EXPECT_NE(d.shrink_compensation, p.shrink_compensation);
  EXPECT_NE(d.flow.cutoff_origin, p.flow.cutoff_origin);
}

}  // namespace
}  // namespace pointfair
