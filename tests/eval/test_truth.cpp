#include "pointfair/eval/truth.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <gtest/gtest.h>

#include "pointfair/common/params_error.hpp"
#include "pointfair/io/point_table.hpp"
#include "pointfair/shapes/mesh_distance.hpp"

namespace pointfair::eval {
namespace {

TruthSpec named(const std::string& shape) {
  TruthSpec t;
  t.shape = shape;
  if (shape == "cylinder") t.length = 2.0;
  return t;
}

constexpr double kTight = 1e-12;

TEST(GroundTruth, CubeSignedDistanceAndCreases) {
  const GroundTruth cube(named("cube"));
  EXPECT_EQ(cube.sharp_edge_count(), 12u);  // the face diagonals are flat, not sharp
  const SurfacePoint out = cube.closest(Vec3(1.5, 0.2, 0.1));
  EXPECT_NEAR(out.signed_distance, 0.5, kTight);
  EXPECT_NEAR(out.normal.x(), 1.0, kTight);
  EXPECT_NEAR(out.crease_distance, 0.8, kTight);  // to the edge y = 1 of the face x = 1
  const SurfacePoint in = cube.closest(Vec3(0.9, 0.0, 0.0));
  EXPECT_NEAR(in.signed_distance, -0.1, kTight);
  // Outside a convex edge and a corner: the pseudo-normals give the outside sign.
  EXPECT_NEAR(cube.closest(Vec3(1.3, 1.4, 0.0)).signed_distance, std::hypot(0.3, 0.4), kTight);
  EXPECT_NEAR(cube.closest(Vec3(2, 2, 2)).signed_distance, std::sqrt(3.0), kTight);
  EXPECT_NEAR(cube.closest(Vec3(2, 2, 2)).crease_distance, 0.0, kTight);
}

TEST(GroundTruth, OctahedronOutsideEdgeIsPositive) {
  // Octahedron faces meet at 109.47°: the face-normal sign test alone would fail here.
  const GroundTruth octa(named("octahedron"));
  const Vec3 p = Vec3(0.5, 0.5, 0.0) + 0.3 * Vec3(1, 1, -0.2).normalized();
  const SurfacePoint s = octa.closest(p);
  EXPECT_GT(s.signed_distance, 0.0);
  EXPECT_NEAR(std::abs(s.signed_distance), distance_to_mesh(p, octahedron_mesh()), kTight);
}

TEST(GroundTruth, AnalyticSurfacesOfPointsMovedAlongTheNormal) {
  const double d = 0.05;
  const GroundTruth sphere([] { auto t = named("sphere"); t.radius = 2.0; return t; }());
  const SurfacePoint s = sphere.closest(Vec3(0, 0, 2.0 + d));
  EXPECT_NEAR(s.signed_distance, d, kTight);
  EXPECT_NEAR(s.k1, 0.5, kTight);

  const GroundTruth torus(named("torus"));
  const SurfacePoint outer = torus.closest(Vec3(1.4 + d, 0, 0));
  EXPECT_NEAR(outer.signed_distance, d, kTight);
  EXPECT_NEAR(outer.k1, 1.0 / 0.4, kTight);
  EXPECT_NEAR(outer.k2, 1.0 / 1.4, kTight);
  const SurfacePoint inner = torus.closest(Vec3(0, 0.6 - d, 0));
  EXPECT_NEAR(inner.signed_distance, d, kTight);
  EXPECT_NEAR(inner.k2, -1.0 / 0.6, kTight);  // saddle side

  const GroundTruth cp(named("cylinder-plane"));
  EXPECT_NEAR(cp.closest(Vec3(0.3, 0.0, 1.0 + d)).signed_distance, d, kTight);
  EXPECT_NEAR(cp.closest(Vec3(0.3, 1.7, d)).signed_distance, d, kTight);
  EXPECT_NEAR(cp.closest(Vec3(0.3, 1.0, 0.0)).crease_distance, 0.0, kTight);
  EXPECT_TRUE(cp.has_creases());

  const GroundTruth enneper(named("enneper"));
  const double u = 0.3, v = -0.5;
  const SurfacePoint e = enneper.closest(enneper_point(u, v) + d * enneper_normal(u, v));
  EXPECT_NEAR(e.signed_distance, d, 1e-9);
  const double w = 1 + u * u + v * v;
  EXPECT_NEAR(e.k1, 2 / (w * w), 1e-7);
}

TEST(GroundTruth, SamplesLieOnTheSurface) {
  for (const char* shape : {"cube", "truncated-octahedron", "sphere", "torus", "cylinder-plane", "enneper", "cylinder"}) {
    const GroundTruth truth(named(shape));
    const SurfaceSamples s = truth.sample(300, 3);
    ASSERT_EQ(s.points.size(), 300u) << shape;
    for (std::size_t i = 0; i < s.points.size(); ++i) {
      const SurfacePoint c = truth.closest(s.points[i]);
      ASSERT_NEAR(c.signed_distance, 0.0, 1e-9) << shape;
      ASSERT_GT(std::abs(c.normal.dot(s.normals[i])), 1.0 - 1e-6) << shape;
    }
  }
}

TEST(GroundTruth, TruncatedOctahedronHasTwoDihedralAngles) {
  const TriangleMesh m = truncated_octahedron_mesh();
  EXPECT_EQ(m.vertices.size(), 24u);
  EXPECT_EQ(m.triangles.size(), 8u * 4 + 6u * 2);
  const GroundTruth truth(named("truncated-octahedron"));
  EXPECT_EQ(truth.sharp_edge_count(), 36u);
  // Closed and outward: the centre is inside.
  EXPECT_LT(truth.closest(Vec3::Zero()).signed_distance, 0.0);
}

TEST(TruthFile, RoundTripAndErrors) {
  const auto dir = std::filesystem::temp_directory_path() / "pointfair_truth_test";
  std::filesystem::create_directories(dir);
  const auto file = dir / "t.truth";
  write_truth_file(file, [] { auto t = named("torus"); t.major = 1.5; t.minor = 0.25; return t; }());
  const TruthSpec back = truth_from_argument(file.string());
  EXPECT_EQ(back.shape, "torus");
  EXPECT_EQ(back.major, 1.5);
  EXPECT_EQ(back.minor, 0.25);
  std::ofstream(dir / "bad.truth") << "hello\n";
  EXPECT_THROW(read_truth_file(dir / "bad.truth"), io::IoError);
  EXPECT_THROW(GroundTruth(named("dodecahedron")), ParamError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace pointfair::eval
