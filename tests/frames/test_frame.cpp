// PCA frames: against Eigen's iterative solver on an explicit covariance about the
// barycentre, exact planes, degenerate neighbourhoods, and precision far from the origin.
#include "pointfair/frames/frame.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

#include <Eigen/Geometry>

#include "pointfair/neighbors/neighborhoods.hpp"
#include "support/checks.hpp"
#include "support/clouds.hpp"
#include "support/reference.hpp"

namespace pointfair {
namespace {

// The closed-form 3x3 solver on the scaled matrix is accurate to a few ulps of the largest
// eigenvalue; eigenvector errors are ~ ulp * c1 / gap. On these clouds the gaps are at least
// ~1e-3 c1, so 1e-10 leaves a margin of ~1e3 over the expected ~1e-13.
constexpr double kFrameTol = 1e-10;
// Orthonormality of the returned frame: a few ulps.
constexpr double kOrthoTol = 1e-14;

TEST(Frame, MatchesIterativeSolverOnNoisyCloud) {
  const std::vector<Vec3> points = test::noisy_cube(3000, 0.01, 31);
  NeighborParams np;
  np.k = 16;
  const Neighborhoods n = build_neighborhoods(points, np);
  int compared_t1 = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto nb = n.of(i);
    const Frame f = compute_frame(points[i], nb, points);
    const test::ref::Frame r = test::ref::frame(points[i], nb, points);
    ASSERT_TRUE(f.valid);
    const double scale = r.c1;
    EXPECT_NEAR(f.c1, r.c1, kFrameTol * scale) << i;
    EXPECT_NEAR(f.c2, r.c2, kFrameTol * scale) << i;
    EXPECT_NEAR(f.c0, r.c0, kFrameTol * scale) << i;
    // Eigenvectors up to sign, where the eigenvalue gap defines them well.
    const double normal_gap = (r.c2 - r.c0) / r.c1;
    if (normal_gap > 1e-3) {
      EXPECT_NEAR(std::abs(f.normal.dot(r.normal)), 1.0, kFrameTol) << i;
    }
    if ((r.c1 - r.c2) / r.c1 > 1e-3) {
      EXPECT_NEAR(std::abs(f.t1.dot(r.v1)), 1.0, kFrameTol) << i;
      ++compared_t1;
    }
    // Barycentre of {p} ∪ N.
    Vec3 c = points[i];
    for (const Index j : nb) c += points[j];
    c /= static_cast<double>(nb.size() + 1);
    EXPECT_NEAR((f.centroid - c).norm(), 0.0, 1e-14);
    // Orthonormal and right-handed.
    EXPECT_NEAR(f.normal.norm(), 1.0, kOrthoTol);
    EXPECT_NEAR(f.t1.norm(), 1.0, kOrthoTol);
    EXPECT_NEAR(f.t2.norm(), 1.0, kOrthoTol);
    EXPECT_NEAR(f.t1.dot(f.t2), 0.0, kOrthoTol);
    EXPECT_NEAR(f.t1.dot(f.normal), 0.0, kOrthoTol);
    EXPECT_NEAR((f.t1.cross(f.t2) - f.normal).norm(), 0.0, kOrthoTol);
    EXPECT_GE(f.c1, f.c2);
    EXPECT_GE(f.c2, f.c0);
  }
  EXPECT_GT(compared_t1, 2500) << "too few points with a clear first tangent direction";
}

TEST(Frame, PlaneGivesExactNormalAndZeroThirdEigenvalue) {
  const std::vector<Vec3> points = test::random_plane(400, 1.0, 8);
  NeighborParams np;
  np.k = 12;
  const Neighborhoods n = build_neighborhoods(points, np);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Frame f = compute_frame(points[i], n.of(i), points);
    ASSERT_TRUE(f.valid);
    // z is exactly 0 in every covariance entry it touches: the normal is z to rounding (a tilt
    // of a few ulps; the tangential components are what a tilt would show).
    EXPECT_LE(f.normal.head<2>().norm(), 1e-14);
    EXPECT_NEAR(f.c0, 0.0, 1e-15 * f.c1);
    EXPECT_EQ(f.centroid.z(), 0.0);
  }
}

TEST(Frame, FromCovarianceOfDiagonalMatrix) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  m.diagonal() << 2.0, 5.0, 0.5;
  const Vec3 centroid(1, 2, 3);
  const Frame f = frame_from_covariance(m, centroid);
  ASSERT_TRUE(f.valid);
  EXPECT_NEAR(f.c1, 5.0, 1e-14);
  EXPECT_NEAR(f.c2, 2.0, 1e-14);
  EXPECT_NEAR(f.c0, 0.5, 1e-14);
  EXPECT_NEAR(std::abs(f.t1.y()), 1.0, 1e-14);
  EXPECT_NEAR(std::abs(f.t2.x()), 1.0, 1e-14);
  EXPECT_NEAR(std::abs(f.normal.z()), 1.0, 1e-14);
  EXPECT_EQ(f.centroid, centroid);

  EXPECT_FALSE(frame_from_covariance(Eigen::Matrix3d::Zero(), centroid).valid);
  Eigen::Matrix3d bad = m;
  bad(0, 0) = std::nan("");
  EXPECT_FALSE(frame_from_covariance(bad, centroid).valid);
  // Rank one: a line has no plane.
  Eigen::Matrix3d line = Eigen::Matrix3d::Zero();
  line(0, 0) = 1.0;
  EXPECT_FALSE(frame_from_covariance(line, centroid).valid);
}

TEST(Frame, RotatedSpectraIncludingNearlyEqualTangentEigenvalues) {
  // Covariances R diag(c1, c2, c0) R^T with known spectra. A closed-form cubic solver alone
  // loses half the digits when c1 ~ c2 (errors ~ sqrt(eps) c1 ~ 1e-8); the frame must get
  // every eigenvalue to a few ulps of c1 (1e-13 leaves a margin of ~100).
  constexpr double kSpectrumTol = 1e-13;
  test::Uniform u(71);
  const std::vector<std::array<double, 3>> spectra = {
      {1.0, 0.5, 0.01}, {1.0, 1.0, 0.01}, {1.0, 1.0 - 1e-9, 1e-3}, {2.0, 2.0 - 1e-6, 0.0},
      {1.0, 1e-3, 1e-3}, {1.0, 0.3, 0.3 - 1e-9}, {5.0, 5.0, 5.0 * 1e-7}};
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Quaterniond q(u.in(-1, 1), u.in(-1, 1), u.in(-1, 1), u.in(-1, 1));
    const Eigen::Matrix3d rot = q.normalized().toRotationMatrix();
    for (const auto& s : spectra) {
      const Eigen::Matrix3d m = rot * Vec3(s[0], s[1], s[2]).asDiagonal() * rot.transpose();
      const Frame f = frame_from_covariance(m, Vec3::Zero());
      ASSERT_TRUE(f.valid);
      EXPECT_NEAR(f.c1, s[0], kSpectrumTol * s[0]);
      EXPECT_NEAR(f.c2 + f.c0, s[1] + s[2], kSpectrumTol * s[0]);
      // The Rayleigh quotients of the returned vectors are the returned eigenvalues.
      EXPECT_NEAR(f.t1.dot(m * f.t1), f.c1, kSpectrumTol * s[0]);
      EXPECT_NEAR(f.t2.dot(m * f.t2), f.c2, kSpectrumTol * s[0]);
      EXPECT_NEAR(f.t1.dot(m * f.t2), 0.0, kSpectrumTol * s[0]);
      // Where the normal's eigenvalue is well separated, the normal is the third axis and c2,
      // c0 are pinned individually. (With c2 ~ c0 the normal is not defined by the data, and
      // neither is the split of c2 + c0 between the returned normal and t2.)
      if (s[1] - s[2] > 1e-4 * s[0]) {
        EXPECT_NEAR(std::abs(f.normal.dot(rot.col(2))), 1.0, 1e-12);
        EXPECT_NEAR(f.c2, s[1], kSpectrumTol * s[0]);
        EXPECT_NEAR(f.c0, s[2], kSpectrumTol * s[0]);
      }
    }
  }
}

TEST(Frame, DegenerateNeighbourhoodsAreInvalid) {
  std::vector<Vec3> points = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0), Vec3(3, 0, 0),
                              Vec3(0, 1, 0)};
  const std::vector<Index> collinear = {1, 2, 3};
  EXPECT_FALSE(compute_frame(points[0], collinear, points).valid);
  const std::vector<Index> one = {4};
  EXPECT_FALSE(compute_frame(points[0], one, points).valid) << "fewer than 3 points";
  const std::vector<Index> none;
  EXPECT_FALSE(compute_frame(points[0], none, points).valid);
  const std::vector<Index> two = {1, 4};
  EXPECT_TRUE(compute_frame(points[0], two, points).valid) << "3 points span a plane";
  const std::vector<Vec3> same(5, Vec3(1, 1, 1));
  const std::vector<Index> all = {1, 2, 3, 4};
  EXPECT_FALSE(compute_frame(same[0], all, same).valid);
}

TEST(Frame, FarFromOriginKeepsPrecision) {
  // The covariance is accumulated relative to p_i, so a cloud at 1e6 (UTM-like coordinates)
  // has the same frames as at the origin up to the rounding of the coordinates themselves:
  // ulp(1e6) ~ 1.2e-10 on offsets of ~0.05 gives relative errors ~ 1e-8 in the offsets.
  constexpr double kFarTol = 1e-6;
  const std::vector<Vec3> near = test::noisy_cube(1000, 0.01, 41);
  const Vec3 offset(1e6, -2e6, 5e5);
  std::vector<Vec3> far;
  for (const Vec3& p : near) far.push_back(p + offset);
  NeighborParams np;
  np.k = 16;
  const Neighborhoods n = build_neighborhoods(near, np);
  for (std::size_t i = 0; i < near.size(); ++i) {
    const Frame a = compute_frame(near[i], n.of(i), near);
    const Frame b = compute_frame(far[i], n.of(i), far);
    if ((a.c2 - a.c0) / a.c1 < 1e-2) continue;
    EXPECT_NEAR(std::abs(a.normal.dot(b.normal)), 1.0, kFarTol) << i;
    EXPECT_NEAR(b.c1, a.c1, kFarTol * a.c1) << i;
    EXPECT_NEAR(b.c0, a.c0, kFarTol * a.c1) << i;
  }
}

TEST(Frame, NormalFromCovarianceMatchesTheFrameOnKnownSpectra) {
  // The Euler step's normal (Laguerre iteration on the characteristic polynomial, no
  // trigonometry) against the known third axis of R diag(c1, c2, c0) R^T, over scales from
  // 1e-8 to 1e4 and c0/c1 from 0 to 0.5 (a noisy neighbourhood); eigenvector errors ~ ulp *
  // c1 / gap, so 1e-12 for gaps >= 1e-3 c1. Where the spectrum is (nearly) degenerate it must
  // agree with frame_from_covariance on validity.
  test::Uniform u(73);
  const std::vector<std::array<double, 3>> spectra = {
      {1.0, 0.5, 0.0},  {1.0, 0.5, 0.01}, {1.0, 0.9, 0.5}, {1.0, 1.0, 0.2},
      {1.0, 0.2, 1e-6}, {1.0, 0.02, 0.01}, {1.0, 0.6, 0.45}};
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Quaterniond q(u.in(-1, 1), u.in(-1, 1), u.in(-1, 1), u.in(-1, 1));
    const Eigen::Matrix3d rot = q.normalized().toRotationMatrix();
    const double scale = std::pow(10.0, u.in(-8, 4));
    for (const auto& s : spectra) {
      const Eigen::Matrix3d m =
          scale * (rot * Vec3(s[0], s[1], s[2]).asDiagonal() * rot.transpose());
      const NormalEstimate e = normal_from_covariance(m);
      ASSERT_TRUE(e.valid) << s[0] << " " << s[1] << " " << s[2];
      EXPECT_NEAR(e.normal.norm(), 1.0, kOrthoTol);
      EXPECT_NEAR(std::abs(e.normal.dot(rot.col(2))), 1.0, 1e-12)
          << s[0] << " " << s[1] << " " << s[2] << " scale " << scale;
    }
  }
  // Degenerate spectra: validity as the frame says, and a unit normal either way.
  const std::vector<std::array<double, 3>> degenerate = {
      {1.0, 0.0, 0.0}, {1.0, 1e-13, 0.0}, {1.0, 1.0, 1.0}, {1.0, 0.3, 0.3}, {0.0, 0.0, 0.0}};
  for (const auto& s : degenerate) {
    const Eigen::Matrix3d m = Vec3(s[0], s[1], s[2]).asDiagonal();
    const NormalEstimate e = normal_from_covariance(m);
    EXPECT_EQ(e.valid, frame_from_covariance(m, Vec3::Zero()).valid) << s[0] << " " << s[1] << " " << s[2];
    EXPECT_NEAR(e.normal.norm(), 1.0, kOrthoTol);
  }
  EXPECT_FALSE(normal_from_covariance(Eigen::Matrix3d::Zero()).valid);
}

}  // namespace
}  // namespace pointfair
