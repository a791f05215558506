// The whole evolution: agreement with hand-driven Euler steps, rebuilds, noise-free
// neighbourhoods, degenerate points, invariances (rigid motion, scaling, permutation), the
// anisotropic flow keeping a cube's edges, per-point attributes, and parameter checks.
#include "pointfair/flow/shrink_compensation.hpp"
#include "pointfair/smooth.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "pointfair/common/params_error.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "support/checks.hpp"
#include "support/clouds.hpp"

namespace pointfair {
namespace {

SmoothParams small_params(int steps) {
  SmoothParams p;
  p.finish.reset();  // the flow alone
  p.neighbors.k = 16;
  p.steps = steps;
  p.flow.tau = 0.5;
  p.flow.lambda_auto_factor = 2.0;
  return p;
}

TEST(Smooth, ZeroStepsReproduceTheInput) {
  const std::vector<Vec3> input = test::noisy_cube(2000, 0.01, 1);
  std::vector<Vec3> points = input;
  const SmoothReport report = smooth(points, small_params(0));
  EXPECT_TRUE(test::bitwise_equal(points, input));
  EXPECT_EQ(report.steps, 0);
  EXPECT_EQ(report.rebuilds, 0);
  EXPECT_EQ(report.neighborhoods.size(), input.size());
  EXPECT_GT(report.eps, 0.0);
  EXPECT_GT(report.lambda, 0.0);
}

TEST(Smooth, EqualsHandDrivenEulerSteps) {
  // smooth() = neighbourhoods of the input, then per step: lambda (measured again before
  // every step if asked), one Jacobi step and its shrinkage compensation (beta 1 by default;
  // 0 copies the step).
  const std::vector<Vec3> input = test::noisy_cube(3000, 0.01, 2);
  for (const bool every : {true, false}) {
    for (const double beta : {1.0, 0.0}) {
      SmoothParams params = small_params(5);
      params.lambda_every_step = every;
      params.shrink_compensation = beta;
      std::vector<Vec3> points = input;
      const SmoothReport report = smooth(points, params);

      const Neighborhoods n = build_neighborhoods(input, params.neighbors);
      std::vector<Vec3> current = input, updated(input.size()), next(input.size());
      double lambda = resolve_lambda(current, n, params.flow);
      for (int s = 0; s < 5; ++s) {
        if (every) lambda = resolve_lambda(current, n, params.flow);
        euler_step(current, n, {}, params.flow, lambda, updated);
        compensate_shrinkage(current, updated, n, {}, beta, next);
        current.swap(next);
      }
      EXPECT_TRUE(test::bitwise_equal(points, current)) << "every step: " << every << ", beta " << beta;
      EXPECT_EQ(report.lambda, lambda);
      EXPECT_EQ(report.steps, 5);
      EXPECT_TRUE(test::same_neighborhoods(report.neighborhoods, n));
    }
  }
}

TEST(Smooth, ExplicitLambdaIsKept) {
  std::vector<Vec3> points = test::noisy_cube(2000, 0.01, 3);
  SmoothParams params = small_params(3);
  params.flow.lambda = 7.5;
  EXPECT_EQ(smooth(points, params).lambda, 7.5);
}

// The isotropic flow measures no threshold between its steps, only the one before its last
// step (the threshold of its attributes), as a measurement before every step would.
TEST(Smooth, IsotropicFlowReportsTheThresholdBeforeItsLastStep) {
  const std::vector<Vec3> cloud = test::noisy_cube(2000, 0.01, 4);
  SmoothParams params = small_params(5);
  params.flow.flow = Flow::Isotropic;
  std::vector<Vec3> five = cloud;
  const SmoothReport report = smooth(five, params);
  params.steps = 4;
  std::vector<Vec3> four = cloud;
  const SmoothReport before = smooth(four, params);
  EXPECT_EQ(report.lambda, auto_lambda(four, before.neighborhoods, params.flow.lambda_auto_factor));
  EXPECT_NE(report.lambda, before.lambda);
  // The steps themselves never read it.
  params.steps = 5;
  params.flow.lambda = 1e-3;
  std::vector<Vec3> fixed = cloud;
  smooth(fixed, params);
  EXPECT_EQ(fixed, five);
}

TEST(Smooth, RebuildIntervalRebuildsNeighbourhoods) {
  const std::vector<Vec3> input = test::noisy_cube(3000, 0.01, 4);
  SmoothParams params = small_params(7);
  params.rebuild_interval = 3;  // rebuilds before steps 3 and 6
  std::vector<Vec3> points = input;
  const SmoothReport report = smooth(points, params);
  EXPECT_EQ(report.rebuilds, 2);
  const Neighborhoods initial = build_neighborhoods(input, params.neighbors);
  EXPECT_FALSE(test::same_neighborhoods(report.neighborhoods, initial));
  // The last rebuild used the positions after 6 steps.
  std::vector<Vec3> six = input;
  SmoothParams six_params = params;
  six_params.steps = 6;
  EXPECT_EQ(smooth(six, six_params).rebuilds, 1);
  EXPECT_TRUE(test::same_neighborhoods(report.neighborhoods, build_neighborhoods(six, params.neighbors)));
  // And the result differs from the run with fixed neighbourhoods.
  std::vector<Vec3> fixed = input;
  params.rebuild_interval = 0;
  const SmoothReport fixed_report = smooth(fixed, params);
  EXPECT_EQ(fixed_report.rebuilds, 0);
  EXPECT_TRUE(test::same_neighborhoods(fixed_report.neighborhoods, initial));
  EXPECT_FALSE(test::bitwise_equal(fixed, points));
}

TEST(Smooth, ProgressIsReportedEveryStep) {
  std::vector<Vec3> points = test::noisy_cube(1000, 0.01, 5);
  std::vector<std::pair<int, int>> calls;
  SmoothOptions options;
  options.progress = [&](SmoothStage stage, std::size_t done, std::size_t total) {
    EXPECT_EQ(stage, SmoothStage::Steps);
    calls.emplace_back(static_cast<int>(done), static_cast<int>(total));
  };
  smooth(points, small_params(4), options);
  const std::vector<std::pair<int, int>> expected = {{1, 4}, {2, 4}, {3, 4}, {4, 4}};
  EXPECT_EQ(calls, expected);
}

TEST(Smooth, NeighbourReferenceMustMatchTheInput) {
  const std::vector<Vec3> input = test::noisy_cube(1000, 0.01, 6);
  const std::vector<Vec3> reference(input.begin(), input.end() - 1);
  std::vector<Vec3> points = input;
  SmoothOptions options;
  options.neighbor_reference = reference;
  EXPECT_THROW(smooth(points, small_params(3), options), ParamError);
  EXPECT_TRUE(test::bitwise_equal(points, input)) << "nothing is done before the check";
}

double rms_radius_error(const std::vector<Vec3>& points, double radius) {
  double sum = 0.0;
  for (const Vec3& p : points) sum += (p.norm() - radius) * (p.norm() - radius);
  return std::sqrt(sum / static_cast<double>(points.size()));
}

TEST(Smooth, NoiseFreeNeighbourhoodsDoBetter) {
  // The paper's Figures 3 and 6d: neighbourhoods from the clean samples (same order) instead
  // of the noisy ones. Unit sphere, 5k points (spacing ~0.05), noise 2% of the diagonal
  // (sigma ~0.07, more than the spacing: the noisy neighbourhoods are badly mixed), 10
  // anisotropic steps. Measured RMS of |p| - 1: noisy 0.0693, noisy neighbourhoods 0.0253,
  // clean neighbourhoods 0.0185. At 0.5% noise the two differ by only ~3%.
  const SurfaceSamples clean = sample_sphere(5000, 1.0, 7);
  std::vector<Vec3> noisy = clean.points;
  add_noise(noisy, 0.02 * bounding_box_diagonal(clean.points), 8);
  const SmoothParams params = small_params(10);
  std::vector<Vec3> own = noisy;
  const SmoothReport own_report = smooth(own, params);
  std::vector<Vec3> guided = noisy;
  SmoothOptions options;
  options.neighbor_reference = clean.points;
  const SmoothReport guided_report = smooth(guided, params, options);
  EXPECT_TRUE(test::same_neighborhoods(guided_report.neighborhoods,
                                       build_neighborhoods(clean.points, params.neighbors)));
  EXPECT_FALSE(test::same_neighborhoods(guided_report.neighborhoods, own_report.neighborhoods));
  const double before = rms_radius_error(noisy, 1.0);
  const double e_own = rms_radius_error(own, 1.0);
  const double e_guided = rms_radius_error(guided, 1.0);
  std::printf("sphere RMS radius error: noisy %.4f, own neighbourhoods %.4f, clean neighbourhoods %.4f\n",
              before, e_own, e_guided);
  EXPECT_LT(e_own, before);
  EXPECT_LT(e_guided, 0.85 * e_own);
}

TEST(Smooth, IsolatedPointIsCountedAndStays) {
  std::vector<Vec3> points = test::random_plane(1000, 1.0, 9);
  const Vec3 far(5.0, 5.0, 5.0);
  points.push_back(far);
  SmoothParams params = small_params(3);
  params.neighbors.eps = 0.2;  // the far point has no neighbour within eps
  const SmoothReport report = smooth(points, params);
  EXPECT_EQ(report.degenerate, 1u);
  EXPECT_EQ(report.neighborhoods.counts.back(), 0);
  EXPECT_EQ(points.back(), far);
}

TEST(Smooth, ValidateRejectsBadParameters) {
  const auto bad = [](auto mutate) {
    SmoothParams p;
    p.finish.reset();  // the flow alone
    mutate(p);
    return p;
  };
  EXPECT_NO_THROW(SmoothParams{}.validate());
  EXPECT_THROW(bad([](SmoothParams& p) { p.steps = -1; }).validate(), ParamError);
  EXPECT_THROW(bad([](SmoothParams& p) { p.rebuild_interval = -2; }).validate(), ParamError);
  EXPECT_THROW(bad([](SmoothParams& p) { p.flow.tau = 0.0; }).validate(), ParamError);
  EXPECT_THROW(bad([](SmoothParams& p) { p.flow.tau = 1.5; }).validate(), ParamError);
  EXPECT_NO_THROW(bad([](SmoothParams& p) { p.neighbors.k = 0; }).validate());  // automatic
  EXPECT_THROW(bad([](SmoothParams& p) { p.neighbors.k = -1; }).validate(), ParamError);
  EXPECT_THROW(bad([](SmoothParams& p) { p.neighbors.k = 1025; }).validate(), ParamError);
  EXPECT_THROW(bad([](SmoothParams& p) { p.flow.features.quotient = -1; }).validate(), ParamError);
  std::vector<Vec3> points = test::random_plane(100, 1.0, 1);
  EXPECT_THROW(smooth(points, bad([](SmoothParams& p) { p.flow.tau = 2.0; })), ParamError);
}

// ---- Invariances (MATH.md): a 3k-point noisy cube, 10 steps. ----

// Rounding differs between the transformed and the original run (~1e-16 relative per
// operation, amplified mildly over 10 steps of a smoothing flow): 1e-9 of the size is far
// above that and far below any real disagreement (a cut-off decision that flips moves a point
// by ~tau * spacing / k ~ 1e-3).
constexpr double kInvarianceTol = 1e-9;

std::vector<Vec3> run(std::vector<Vec3> points, const SmoothParams& params) {
  smooth(points, params);
  return points;
}

TEST(Smooth, RigidMotionCommutes) {
  const std::vector<Vec3> input = test::noisy_cube(3000, 0.01, 10);
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(0.7, Vec3(1, -2, 0.5).normalized()).toRotationMatrix();
  const Vec3 shift(3.0, -1.5, 10.0);
  std::vector<Vec3> moved;
  for (const Vec3& p : input) moved.push_back(rot * p + shift);
  const double size = bounding_box_diagonal(input);
  for (const Cutoff cutoff : {Cutoff::Sharp, Cutoff::Continuous}) {
    SmoothParams params = small_params(10);
    params.flow.cutoff = cutoff;
    const std::vector<Vec3> a = run(input, params);
    const std::vector<Vec3> b = run(moved, params);
    std::vector<Vec3> a_moved;
    for (const Vec3& p : a) a_moved.push_back(rot * p + shift);
    EXPECT_LE(test::max_distance(a_moved, b), kInvarianceTol * size);
    EXPECT_GT(test::max_distance(a, input), 1e-3 * size) << "the flow moved the points";
  }
}

TEST(Smooth, ScalingCommutesWithLambdaScaledInversely) {
  const std::vector<Vec3> input = test::noisy_cube(3000, 0.01, 11);
  const double size = bounding_box_diagonal(input);
  constexpr double s = 3.7;  // not a power of two: rounding differs
  std::vector<Vec3> scaled;
  for (const Vec3& p : input) scaled.push_back(s * p);
  // Explicit lambda (1/length) scaled by 1/s with explicit eps scaled by s; then both
  // automatic (measured lengths and curvatures scale by themselves).
  for (const bool automatic : {false, true}) {
    SmoothParams a_params = small_params(10);
    SmoothParams b_params = a_params;
    if (!automatic) {
      a_params.flow.lambda = 12.0;
      b_params.flow.lambda = 12.0 / s;
      a_params.neighbors.eps = 0.15;
      b_params.neighbors.eps = 0.15 * s;
    }
    const std::vector<Vec3> a = run(input, a_params);
    const std::vector<Vec3> b = run(scaled, b_params);
    double worst = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, (s * a[i] - b[i]).norm());
    EXPECT_LE(worst, kInvarianceTol * s * size) << "automatic: " << automatic;
    EXPECT_GT(test::max_distance(a, input), 1e-3 * size);
  }
}

TEST(Smooth, PermutationPermutesTheOutput) {
  // A random (tie-free) cloud: neighbour lists hold the same points in the same order, so the
  // sums run in the same order and the results are bit-identical.
  const std::vector<Vec3> input = test::noisy_cube(3000, 0.01, 12);
  std::vector<std::size_t> perm(input.size());
  std::iota(perm.begin(), perm.end(), std::size_t{0});
  std::shuffle(perm.begin(), perm.end(), std::mt19937_64(13));
  std::vector<Vec3> permuted(input.size());
  for (std::size_t i = 0; i < input.size(); ++i) permuted[i] = input[perm[i]];
  for (const Cutoff cutoff : {Cutoff::Sharp, Cutoff::Continuous}) {
    SmoothParams params = small_params(10);
    params.flow.cutoff = cutoff;
    const std::vector<Vec3> a = run(input, params);
    const std::vector<Vec3> b = run(permuted, params);
    int different = 0;
    for (std::size_t i = 0; i < input.size(); ++i) different += b[i] != a[perm[i]];
    EXPECT_EQ(different, 0);
  }
}

// ---- The paper's claim: the anisotropic flow keeps sharp edges that the isotropic one rounds.

struct CubeScores {
  double edge = 0.0;  // RMS distance to the true surface, points sampled within 0.1 of an edge
  double face = 0.0;  // the same for points farther than 0.2 from every edge
};

CubeScores score_cube(const std::vector<Vec3>& clean, const std::vector<Vec3>& points) {
  double se = 0.0, sf = 0.0;
  int ne = 0, nf = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double d = test::cube_surface_distance(points[i]);
    const double to_edge = test::cube_edge_distance(clean[i]);
    const double to_corner = (clean[i].cwiseAbs() - Vec3::Ones()).norm();
    if (to_corner < 0.15) continue;
    if (to_edge < 0.1) {
      se += d * d;
      ++ne;
    } else if (to_edge > 0.2) {
      sf += d * d;
      ++nf;
    }
  }
  return {std::sqrt(se / ne), std::sqrt(sf / nf)};
}

TEST(Smooth, AnisotropicFlowKeepsCubeEdges) {
  // 10k area-uniform samples of [-1, 1]^3 (spacing ~0.05), Gaussian noise 0.5% of the
  // diagonal (sigma ~0.017), k = 16, tau = 0.5, 10 steps, lambda = 2 x median |kappa| measured
  // before every step, sharp cut-off. Measured RMS distance to the cube (edge band / faces):
  //   noisy input   0.0170 / 0.0170
  //   isotropic     0.0333 / 0.0024   (edges rounded off)
  //   anisotropic   0.0157 / 0.0053   (edges kept, faces flattened)
  const std::vector<Vec3> clean = sample_mesh(cube_mesh(), 10000, 7).points;
  std::vector<Vec3> noisy = clean;
  add_noise(noisy, 0.005 * bounding_box_diagonal(clean), 8);
  // The paper's flows, uncompensated: the compensated isotropic flow rounds the edges less.
  SmoothParams params = small_params(10);
  params.shrink_compensation = 0.0;
  params.flow.cutoff = Cutoff::Sharp;
  params.lambda_every_step = true;
  const std::vector<Vec3> aniso = run(noisy, params);
  params.flow.flow = Flow::Isotropic;
  const std::vector<Vec3> iso = run(noisy, params);
  const CubeScores s0 = score_cube(clean, noisy);
  const CubeScores sa = score_cube(clean, aniso);
  const CubeScores si = score_cube(clean, iso);
  std::printf("cube RMS edge/face: noisy %.4f/%.4f, isotropic %.4f/%.4f, anisotropic %.4f/%.4f\n",
              s0.edge, s0.face, si.edge, si.face, sa.edge, sa.face);
  EXPECT_LT(sa.edge, 0.6 * si.edge) << "edges kept clearly better than by the isotropic flow";
  EXPECT_LT(sa.edge, s0.edge) << "and not made worse than the input";
  EXPECT_LT(sa.face, 0.4 * s0.face) << "while the faces are denoised";
  EXPECT_LT(si.face, 0.4 * s0.face);
}

// ---- Attributes ----

TEST(Smooth, AttributesOnSphereAreOrientedOutward) {
  const SurfaceSamples s = sample_sphere(4000, 2.0, 14);
  const Neighborhoods n = build_neighborhoods(s.points, NeighborParams{});
  FlowParams params;
  const double lambda = auto_lambda(s.points, n, 2.0);
  const PointAttributes a = compute_attributes(s.points, n, params, lambda);
  ASSERT_EQ(a.normal.size(), s.points.size());
  EXPECT_EQ(a.degenerate, 0u);
  double mean_k = 0.0;
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    EXPECT_GT(a.normal[i].dot(s.normals[i]), 0.9) << "outward";
    EXPECT_GE(a.k1[i], a.k2[i]);
    EXPECT_NEAR(a.mean_curvature[i], 0.5 * (a.k1[i] + a.k2[i]), 1e-12);
    EXPECT_NEAR(a.d1[i].dot(a.normal[i]), 0.0, 1e-12);
    EXPECT_NEAR(a.d1[i].dot(a.d2[i]), 0.0, 1e-12);
    EXPECT_GE(a.laplacian_norm[i], 0.0);
    mean_k += a.mean_curvature[i];
  }
  mean_k /= static_cast<double>(s.points.size());
  // Reported curvatures are positive where the surface is convex (outward normals), so the
  // mean curvature is about +1/R = 0.5 (the estimator's own error is ~0.1 on such samples).
  EXPECT_NEAR(mean_k, 0.5, 0.05);
  const Neighborhoods wrong = build_neighborhoods(std::vector<Vec3>(s.points.begin(), s.points.end() - 1), NeighborParams{});
  EXPECT_THROW(compute_attributes(s.points, wrong, params, lambda), ParamError);
}

// The normals alone are compute_attributes' normals to the bit, with its count of degenerate
// points, for the PCA and the gated robust frames, on a cloud with points that span no plane.
TEST(Smooth, NormalsAloneAreTheAttributesNormals) {
  const SurfaceSamples s = sample_sphere(3000, 2.0, 15);
  std::vector<Vec3> points = s.points;
  add_noise(points, 0.01, 16);
  // Three points on a line far from the sphere: their own neighbourhoods span no plane.
  for (int j = 0; j < 3; ++j) points.push_back(Vec3(10.0 + 0.1 * j, 10.0, 10.0));
  NeighborParams near;
  near.k = 2;
  Neighborhoods n = build_neighborhoods(points, NeighborParams{});
  const Neighborhoods line = build_neighborhoods(points, near);
  for (std::size_t i = s.points.size(); i < points.size(); ++i) {
    n.counts[i] = line.counts[i];
    std::copy(line.of(i).begin(), line.of(i).end(), n.indices.begin() + static_cast<std::ptrdiff_t>(i * static_cast<std::size_t>(n.stride)));
  }
  for (const NormalEstimator estimator : {NormalEstimator::Pca, NormalEstimator::Robust}) {
    FlowParams params;
    params.normal_estimator = estimator;
    params.robust.gate = 2.0;
    const double lambda = auto_lambda(points, n, 2.0);
    const PointAttributes all = compute_attributes(points, n, params, lambda);
    const PointAttributes normals = compute_normals(points, n, params, lambda);
    EXPECT_EQ(normals.normal, all.normal);
    EXPECT_EQ(normals.degenerate, all.degenerate);
    EXPECT_GE(all.degenerate, 3u);
    EXPECT_TRUE(normals.k1.empty() && normals.d1.empty() && normals.feature.empty());
  }
  const Neighborhoods wrong = build_neighborhoods(std::vector<Vec3>(points.begin(), points.end() - 1), NeighborParams{});
  EXPECT_THROW(compute_normals(points, wrong, FlowParams{}, 1.0), ParamError);
}

}  // namespace
}  // namespace pointfair
