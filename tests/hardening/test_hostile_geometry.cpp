// Degenerate and extreme geometry through the library: every case ends with finite positions,
// a defined outcome (points that cannot move stay put and are counted as degenerate), or a
// ParamError before any work. docs/hostile-inputs.md lists these outcomes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "pointfair/common/params_error.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "pointfair/smooth.hpp"
#include "support/clouds.hpp"

using namespace pointfair;

namespace {

bool all_finite(const std::vector<Vec3>& points) {
  for (const Vec3& p : points)
    if (!p.allFinite()) return false;
  return true;
}

bool attributes_finite(const PointAttributes& a) {
  for (std::size_t i = 0; i < a.k1.size(); ++i) {
    if (!a.normal[i].allFinite() || !a.d1[i].allFinite() || !a.d2[i].allFinite()) return false;
    if (!std::isfinite(a.k1[i]) || !std::isfinite(a.k2[i]) || !std::isfinite(a.mean_curvature[i]) ||
        !std::isfinite(a.laplacian_norm[i]))
      return false;
  }
  return true;
}

// Runs smooth() and compute_attributes() for both flows; returns the anisotropic result.
struct Outcome {
  std::vector<Vec3> positions;
  SmoothReport report;
  PointAttributes attributes;
};

Outcome run(std::vector<Vec3> points, SmoothParams params) {
  Outcome o;
  o.report = smooth(points, params);
  o.attributes = compute_attributes(points, o.report.neighborhoods, params.flow, o.report.lambda);
  o.positions = std::move(points);
  return o;
}

SmoothParams few_steps(int steps = 5) {
  SmoothParams p;
  p.finish.reset();  // the flow alone
  p.steps = steps;
  return p;
}

std::vector<Vec3> noisy_sphere(std::size_t n, double noise, std::uint64_t seed) {
  std::vector<Vec3> points = sample_sphere(n, 1.0, seed).points;
  add_noise(points, noise, seed + 1);
  return points;
}

}  // namespace

TEST(HostileGeometry, EmptyAndTinyCloudsAreUnchanged) {
  for (std::size_t n : {0u, 1u, 2u}) {
    SCOPED_TRACE(n);
    std::vector<Vec3> points;
    for (std::size_t i = 0; i < n; ++i) points.emplace_back(static_cast<double>(i), 0.5, -1.0);
    const Outcome o = run(points, few_steps());
    EXPECT_EQ(o.positions, points);
    EXPECT_EQ(o.report.degenerate, n);
    EXPECT_EQ(o.attributes.degenerate, n);
    EXPECT_TRUE(attributes_finite(o.attributes));
    // The umbrella operator needs no plane: with tau 0.5 two points meet at their midpoint.
    SmoothParams iso = few_steps();
    iso.flow.flow = Flow::Isotropic;
    iso.flow.tau = 0.5;
    iso.shrink_compensation = 0.0;
    const Outcome u = run(points, iso);
    // Compensated, they swap sides around it and do not fly apart (the compensation's cap,
    // shrink_compensation.hpp): with tau 0.8 closer each step, with the defaults' tau 1 at
    // the same distance (the cap's factor 1 - 2 tau).
    SmoothParams compensated = few_steps();
    compensated.flow.flow = Flow::Isotropic;
    const Outcome c = run(points, compensated);
    SmoothParams shorter = compensated;
    shorter.flow.tau = 0.8;
    const Outcome c8 = run(points, shorter);
    if (n == 2) {
      EXPECT_EQ(u.positions[0], u.positions[1]);
      EXPECT_EQ(u.positions[0], Vec3(0.5, 0.5, -1.0));
      EXPECT_LT((c8.positions[1] - c8.positions[0]).norm(), 1.0);
      EXPECT_NEAR((c.positions[1] - c.positions[0]).norm(), 1.0, 1e-12);
      for (const Outcome* swapped : {&c, &c8})
        EXPECT_NEAR((0.5 * (swapped->positions[0] + swapped->positions[1]) - Vec3(0.5, 0.5, -1.0)).norm(), 0.0,
                    1e-12);
    } else {
      EXPECT_EQ(u.positions, points);
      EXPECT_EQ(c.positions, points);
      EXPECT_EQ(c8.positions, points);
    }
  }
}

TEST(HostileGeometry, AllPointsIdenticalStayPutAndAreDegenerate) {
  const std::vector<Vec3> points(200, Vec3(3.0, -2.0, 7.5));
  for (const double eps : {0.0, 0.1, std::numeric_limits<double>::infinity()}) {
    SCOPED_TRACE(eps);
    SmoothParams p = few_steps();
    p.neighbors.eps = eps;
    const Outcome o = run(points, p);
    EXPECT_EQ(o.positions, points);
    EXPECT_EQ(o.report.degenerate, points.size());
    EXPECT_EQ(o.attributes.degenerate, points.size());
    EXPECT_TRUE(attributes_finite(o.attributes));
  }
}

TEST(HostileGeometry, EveryPointDuplicatedGivesFiniteResultsAndKeepsTwinsTogether) {
  // Each point twice: the twin is the nearest neighbour at distance zero.
  const std::vector<Vec3> base = noisy_sphere(1500, 0.01, 11);
  std::vector<Vec3> points;
  for (const Vec3& q : base) {
    points.push_back(q);
    points.push_back(q);
  }
  for (const Flow flow : {Flow::Anisotropic, Flow::Isotropic}) {
    SmoothParams p = few_steps(10);
    p.flow.flow = flow;
    const Outcome o = run(points, p);
    ASSERT_TRUE(all_finite(o.positions));
    EXPECT_TRUE(attributes_finite(o.attributes));
    double moved = 0;
    for (std::size_t i = 0; i < points.size(); ++i) moved = std::max(moved, (o.positions[i] - points[i]).norm());
    EXPECT_GT(moved, 0.0);  // the flow still runs
    EXPECT_LT(moved, 0.2);
    // Twins see the same points (each other instead of themselves), so they move alike.
    double apart = 0;
    for (std::size_t i = 0; i < points.size(); i += 2) apart = std::max(apart, (o.positions[i] - o.positions[i + 1]).norm());
    EXPECT_LT(apart, 0.05);
  }
}

TEST(HostileGeometry, CollinearPointsAreDegenerate) {
  std::vector<Vec3> points;
  for (int i = 0; i < 300; ++i) points.emplace_back(0.01 * i, 0.02 * i, -0.005 * i);
  // Anisotropic: no plane, no normal, so no point moves.
  const Outcome o = run(points, few_steps());
  EXPECT_EQ(o.positions, points);
  EXPECT_EQ(o.report.degenerate, points.size());
  EXPECT_EQ(o.attributes.degenerate, points.size());
  EXPECT_TRUE(attributes_finite(o.attributes));
  // Isotropic: the umbrella operator needs no plane; points move along their line only.
  SmoothParams iso = few_steps();
  iso.flow.flow = Flow::Isotropic;
  const Outcome u = run(points, iso);
  ASSERT_TRUE(all_finite(u.positions));
  EXPECT_TRUE(attributes_finite(u.attributes));
  const Vec3 direction = Vec3(0.01, 0.02, -0.005).normalized();
  for (const Vec3& q : u.positions) EXPECT_LT(q.cross(direction).norm(), 1e-12);
}

TEST(HostileGeometry, CoplanarPointsStayInTheirPlane) {
  const std::vector<Vec3> points = test::random_plane(2000, 1.0, 5);
  for (const Flow flow : {Flow::Anisotropic, Flow::Isotropic}) {
    SmoothParams p = few_steps(10);
    p.flow.flow = flow;
    const Outcome o = run(points, p);
    ASSERT_TRUE(all_finite(o.positions));
    EXPECT_TRUE(attributes_finite(o.attributes));
    for (const Vec3& q : o.positions) ASSERT_EQ(q.z(), 0.0);
    for (std::size_t i = 0; i < points.size(); ++i) {
      EXPECT_NEAR(std::abs(o.attributes.normal[i].z()), 1.0, 1e-12);
      EXPECT_NEAR(o.attributes.k1[i], 0.0, 1e-9);
      EXPECT_NEAR(o.attributes.k2[i], 0.0, 1e-9);
    }
  }
}

TEST(HostileGeometry, FewerPointsThanKUseEveryOtherPoint) {
  // Five points of a sphere with k = 16: each point's neighbourhood is the other four.
  const std::vector<Vec3> points = sample_sphere(5, 1.0, 3).points;
  SmoothParams p = few_steps(3);
  p.neighbors.eps = std::numeric_limits<double>::infinity();
  const Outcome o = run(points, p);
  ASSERT_TRUE(all_finite(o.positions));
  EXPECT_TRUE(attributes_finite(o.attributes));
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(o.report.neighborhoods.counts[i], 4);
}

TEST(HostileGeometry, KLargerThanTheCloud) {
  // k at its maximum (1024) on 300 points, with the automatic eps and without a bound.
  const std::vector<Vec3> points = noisy_sphere(300, 0.01, 7);
  for (const double eps : {0.0, std::numeric_limits<double>::infinity()}) {
    SCOPED_TRACE(eps);
    SmoothParams p = few_steps(3);
    p.neighbors.k = 1024;
    p.neighbors.eps = eps;
    const Outcome o = run(points, p);
    ASSERT_TRUE(all_finite(o.positions));
    EXPECT_TRUE(attributes_finite(o.attributes));
    if (std::isinf(eps)) {
      for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(o.report.neighborhoods.counts[i], 299);
    }
  }
  SmoothParams p = few_steps(1);
  p.neighbors.k = 1025;
  std::vector<Vec3> copy = points;
  EXPECT_THROW(smooth(copy, p), ParamError);
}

TEST(HostileGeometry, EpsSmallerThanEverySpacingLeavesEveryPointAlone) {
  const std::vector<Vec3> points = noisy_sphere(1000, 0.01, 9);
  for (const double eps : {1e-9, std::numeric_limits<double>::denorm_min()}) {
    SCOPED_TRACE(eps);
    SmoothParams p = few_steps();
    p.neighbors.eps = eps;
    const Outcome o = run(points, p);
    EXPECT_EQ(o.positions, points);
    for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(o.report.neighborhoods.counts[i], 0);
    EXPECT_EQ(o.report.degenerate, points.size());
    EXPECT_EQ(o.attributes.degenerate, points.size());
    EXPECT_TRUE(attributes_finite(o.attributes));
  }
}

TEST(HostileGeometry, BadParametersAreRefusedBeforeAnyWork) {
  std::vector<Vec3> points = noisy_sphere(100, 0.01, 1);
  const std::vector<Vec3> before = points;
  const auto refused = [&](auto change) {
    SmoothParams p = few_steps(1);
    change(p);
    EXPECT_THROW(smooth(points, p), ParamError);
    EXPECT_EQ(points, before);
  };
  refused([](SmoothParams& p) { p.neighbors.eps = std::numeric_limits<double>::quiet_NaN(); });
  refused([](SmoothParams& p) { p.neighbors.eps = -1.0; });
  refused([](SmoothParams& p) { p.neighbors.k = -1; });  // 0 is the automatic k
  refused([](SmoothParams& p) { p.flow.tau = std::numeric_limits<double>::quiet_NaN(); });
  refused([](SmoothParams& p) { p.flow.lambda = std::numeric_limits<double>::infinity(); });
  refused([](SmoothParams& p) { p.steps = -1; });
}

// UTM-like coordinates: eastings ~5e5 m, northings ~5e6 m, a 20 m cube sampled with 1 mm
// noise, against the same cloud translated to the origin (both start from the same rounded
// geometry, so only the flow's own rounding differs; one ulp at 5e6 m is 9.3e-10 m).
// The kernels only use differences of positions: with a fixed lambda or the isotropic flow
// every point's displacement agrees within 1e-9 of the bounding-box diagonal (measured:
// 6e-11). With the automatic lambda measured before every step, lambda itself differs in
// the ninth digit from the second step on, and the sharp cut-off is discontinuous: pairs
// whose |kappa| lies within rounding of lambda flip, and the flips spread over the steps.
// The first step still agrees within 1e-9; after 20 steps individual points differed by up to
// about 1% of the diagonal (RMS 5e-4) with the cut-off measured from the point and no
// automatic stop, and by 5e-11 with the cut-off from the plane and the automatic stop, as
// they would for any 1e-9 perturbation of the input.
namespace {

struct FarAndNear {
  std::vector<Vec3> local, far;
  Vec3 offset{512345.678, 5412345.678, 312.5};
  double diagonal = 0;
  FarAndNear() {
    local = sample_mesh(cube_mesh(), 6000, 21).points;
    for (Vec3& p : local) p *= 10.0;  // a 20 m cube
    add_noise(local, 0.001, 22);
    far = local;
    for (Vec3& p : far) p += offset;
    for (std::size_t i = 0; i < far.size(); ++i) local[i] = far[i] - offset;
    diagonal = bounding_box_diagonal(local);
  }
  // Largest and RMS difference of the displacements, over the diagonal.
  std::pair<double, double> compare(const SmoothParams& p) const {
    const Outcome near_run = run(local, p), far_run = run(far, p);
    EXPECT_TRUE(all_finite(far_run.positions));
    EXPECT_TRUE(attributes_finite(far_run.attributes));
    double worst = 0, sum2 = 0;
    for (std::size_t i = 0; i < local.size(); ++i) {
      const double d = ((far_run.positions[i] - far[i]) - (near_run.positions[i] - local[i])).norm();
      worst = std::max(worst, d);
      sum2 += d * d;
    }
    return {worst / diagonal, std::sqrt(sum2 / static_cast<double>(local.size())) / diagonal};
  }
};

}  // namespace

TEST(HostileGeometry, HugeCoordinatesMatchTheCloudAtTheOrigin) {
  constexpr double kRelativeTolerance = 1e-9;
  const FarAndNear clouds;
  SmoothParams fixed = few_steps(20);
  fixed.flow.lambda = 0.002;  // 1/m, about the automatic value of this cloud
  // With tau 1 (the defaults') and this fixed lambda, the points along the cube's edges meet
  // their kept neighbours within ten steps (66 exact duplicates after 10, 180 after 20; with
  // tau 0.8 they come within 1e-6 m and do not meet): where a point's neighbours then lie on
  // one line its plane is undetermined, rounding picks it, and the cut-off flips (measured:
  // RMS 4e-7 of the diagonal after 20 steps). Bounded, as with the automatic lambda below;
  // bit-close with tau 0.8.
  const auto [fixed_worst, fixed_rms] = clouds.compare(fixed);
  EXPECT_LT(fixed_worst, 0.05);
  EXPECT_LT(fixed_rms, 2e-3);
  fixed.flow.tau = 0.8;
  EXPECT_LT(clouds.compare(fixed).first, kRelativeTolerance);
  SmoothParams iso = few_steps(20);
  iso.flow.flow = Flow::Isotropic;
  EXPECT_LT(clouds.compare(iso).first, kRelativeTolerance);
  EXPECT_LT(clouds.compare(few_steps(1)).first, kRelativeTolerance);
  // The automatic lambda every step: bounded, not bit-close (see above).
  const auto [worst, rms] = clouds.compare(few_steps(20));
  EXPECT_LT(worst, 0.05);
  EXPECT_LT(rms, 2e-3);
}

// NaN and infinite coordinates through the library (the readers already refuse such files):
// a ParamError naming the first bad point before any work, the caller's positions untouched.
TEST(HostileGeometry, NonFiniteCoordinatesAreRefusedBeforeAnyWork) {
  const double bad_values[] = {std::numeric_limits<double>::quiet_NaN(),
                               std::numeric_limits<double>::infinity(),
                               -std::numeric_limits<double>::infinity()};
  for (const double bad : bad_values) {
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<Vec3> points = noisy_sphere(500, 0.01, 7);
      points[123][axis] = bad;
      const std::vector<Vec3> before = points;
      try {
        smooth(points, few_steps());
        FAIL() << "smooth accepted a non-finite coordinate";
      } catch (const ParamError& e) {
        EXPECT_NE(std::string(e.what()).find("point 123 has a non-finite coordinate"),
                  std::string::npos)
            << e.what();
      }
      ASSERT_EQ(points.size(), before.size());
      EXPECT_EQ(std::memcmp(points.data(), before.data(), points.size() * sizeof(Vec3)), 0);
      EXPECT_THROW(build_neighborhoods(points, NeighborParams{}), ParamError);
    }
  }
  // A clean neighbour reference does not let a NaN in the positions through.
  std::vector<Vec3> points = noisy_sphere(500, 0.01, 7);
  const std::vector<Vec3> reference = points;
  points[7].x() = std::numeric_limits<double>::quiet_NaN();
  SmoothOptions options;
  options.neighbor_reference = reference;
  EXPECT_THROW(smooth(points, few_steps(), options), ParamError);
}

// Extreme magnitudes: a cloud scaled by a power of two keeps its normals and curvatures (scaled
// by the inverse), from 2^-330 (~1e-99) to 2^330 (~1e99). Around 1e40 the normals' iteration
// overflowed (products of four covariance entries): zero normals and k = 0 while the summary
// said "0 degenerate".
TEST(HostileGeometry, ExtremeMagnitudesKeepNormalsAndCurvatures) {
  std::vector<Vec3> unit = sample_sphere(600, 1.0, 21).points;
  add_noise(unit, 0.005, 22);
  SmoothParams params;
  params.steps = 1;
  params.finish.reset();
  std::vector<Vec3> reference = unit;
  const SmoothReport report = smooth(reference, params);
  const PointAttributes expected = compute_attributes(reference, report.neighborhoods, params.flow, report.lambda);
  ASSERT_EQ(expected.degenerate, 0u);
  for (const int exponent : {-330, -200, 100, 133, 140, 200, 330}) {
    SCOPED_TRACE(exponent);
    const double scale = std::ldexp(1.0, exponent);
    std::vector<Vec3> scaled = unit;
    for (Vec3& p : scaled) p *= scale;
    const SmoothReport r = smooth(scaled, params);
    EXPECT_EQ(r.degenerate, 0u);
    const PointAttributes a = compute_attributes(scaled, r.neighborhoods, params.flow, r.lambda);
    EXPECT_EQ(a.degenerate, 0u);
    double worst_normal = 0, worst_k = 0, worst_position = 0;
    for (std::size_t i = 0; i < unit.size(); ++i) {
      worst_normal = std::max(worst_normal, std::min((a.normal[i] - expected.normal[i]).norm(),
                                                     (a.normal[i] + expected.normal[i]).norm()));
      worst_k = std::max(worst_k, std::abs(a.k1[i] * scale - expected.k1[i]));
      worst_position = std::max(worst_position, (scaled[i] / scale - reference[i]).norm());
    }
    EXPECT_LT(worst_normal, 1e-9);
    EXPECT_LT(worst_k, 1e-6);
    EXPECT_LT(worst_position, 1e-12);
  }
}
