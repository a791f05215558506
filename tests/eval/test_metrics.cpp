#include "pointfair/eval/metrics.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "pointfair/common/params_error.hpp"

namespace pointfair::eval {
namespace {

TruthSpec named(const std::string& shape) {
  TruthSpec t;
  t.shape = shape;
  if (shape == "cylinder") t.length = 2.0;
  return t;
}

TEST(Evaluate, CleanSamplesScoreZeroDistance) {
  const GroundTruth sphere(named("sphere"));
  const SurfaceSamples s = sphere.sample(4000, 1);
  const EvalReport r = evaluate(sphere, {s.points, s.points, s.points});
  EXPECT_LT(r.rms_distance, 1e-14);
  EXPECT_LT(r.max_distance, 1e-14);
  EXPECT_DOUBLE_EQ(r.chamfer_1e4, 0.0);  // reference == cloud
  EXPECT_LT(r.p2m_1e4, 1e-20);
  EXPECT_EQ(*r.max_displacement, 0.0);
  EXPECT_LT(r.normal_all.mean_degrees, 2.0);  // PCA of 16 neighbours on a unit sphere
  EXPECT_FALSE(r.feature_recall.has_value());  // no creases
  ASSERT_TRUE(r.curvature_rms.has_value());
  EXPECT_LT(*r.curvature_rms, 1.0);
}

TEST(Evaluate, PointsMovedAlongTheNormalByD) {
  const GroundTruth sphere(named("sphere"));
  const SurfaceSamples s = sphere.sample(2000, 2);
  const double d = 0.01;
  std::vector<Vec3> moved = s.points;
  for (std::size_t i = 0; i < moved.size(); ++i) moved[i] += (i % 2 ? d : -d) * s.normals[i];
  EvalParams params;
  params.with_curvature = false;
  const EvalReport r = evaluate(sphere, {moved, s.points, s.points}, params);
  const double diag = 2 * std::sqrt(3.0);
  EXPECT_NEAR(r.rms_distance * diag, d, 1e-12);
  EXPECT_NEAR(r.max_distance * diag, d, 1e-12);
  EXPECT_NEAR(r.mean_signed_distance * diag, 0.0, 1e-12);
  EXPECT_NEAR(*r.max_displacement * diag, d, 1e-12);
  // Unit-sphere P2M: the reference's radius is ~1, so P2M ~ d^2 x 1e4 = 1.
  EXPECT_NEAR(r.p2m_1e4, 1.0, 0.01);

  // All points inside by d: the shrinkage shows as a negative mean signed distance.
  std::vector<Vec3> shrunk = s.points;
  for (std::size_t i = 0; i < shrunk.size(); ++i) shrunk[i] -= d * s.normals[i];
  const EvalReport rs = evaluate(sphere, {shrunk, {}, {}}, params);
  EXPECT_NEAR(rs.mean_signed_distance * diag, -d, 1e-12);
  EXPECT_LT(rs.bbox_diagonal_change, -0.009);
}

TEST(Evaluate, EdgeBandSplitsTheCube) {
  const GroundTruth cube(named("cube"));
  const SurfaceSamples s = cube.sample(20000, 4);
  const EvalReport r = evaluate(cube, {s.points, s.points, {}});
  // Band 1% of the diagonal (0.0346) on both sides of 12 edges of length 2 over area 24:
  // about 12 * 2 * 2 * 0.0346 / 24 = 6.9% of the points.
  const double fraction = static_cast<double>(r.normal_edges.count) / 20000.0;
  EXPECT_NEAR(fraction, 0.069, 0.01);
  EXPECT_GT(r.normal_edges.mean_degrees, 10.0);  // PCA normals straddle the edge
  EXPECT_LT(r.normal_elsewhere.mean_degrees, 2.0);
  ASSERT_TRUE(r.feature_recall.has_value());
  EXPECT_EQ(r.feature_true, r.normal_edges.count);
}

TEST(Evaluate, RejectsMismatchedInput) {
  const GroundTruth sphere(named("sphere"));
  const SurfaceSamples s = sphere.sample(100, 1);
  const std::vector<Vec3> fewer(s.points.begin(), s.points.begin() + 50);
  EXPECT_THROW(evaluate(sphere, {s.points, {}, fewer}), ParamError);
  EXPECT_THROW(evaluate(sphere, {{}, {}, {}}), ParamError);
}

TEST(LineAngle, IgnoresSign) {
  EXPECT_NEAR(line_angle_degrees(Vec3::UnitZ(), -Vec3::UnitZ()), 0.0, 1e-6);
  EXPECT_NEAR(line_angle_degrees(Vec3::UnitZ(), Vec3(1, 0, 1)), 45.0, 1e-9);
}

}  // namespace
}  // namespace pointfair::eval
