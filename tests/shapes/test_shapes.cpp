// Test shapes and samplers: the 4-1 subdivided octahedron, the cube, area-uniform mesh
// samples, spheres, cylinders, and the seeded Gaussian noise.
#include "pointfair/shapes/shapes.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <set>
#include <utility>
#include <vector>

#include "pointfair/common/params_error.hpp"
#include "support/checks.hpp"

namespace pointfair {
namespace {

// Points are built from exact vertices with a handful of operations: a few ulps.
constexpr double kOnSurfaceTol = 1e-14;

double mesh_area(const TriangleMesh& m) {
  double area = 0.0;
  for (const auto& t : m.triangles)
    area += 0.5 * (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]).norm();
  return area;
}

// Every triangle's normal points away from the origin (both meshes are convex about it).
void expect_outward(const TriangleMesh& m) {
  for (const auto& t : m.triangles) {
    const Vec3& a = m.vertices[t[0]];
    const Vec3 n = (m.vertices[t[1]] - a).cross(m.vertices[t[2]] - a);
    EXPECT_GT(n.dot(a + m.vertices[t[1]] + m.vertices[t[2]]), 0.0);
  }
}

TEST(Shapes, OctahedronSubdivision) {
  for (int level = 0; level <= 5; ++level) {
    const TriangleMesh m = subdivide_4_1(octahedron_mesh(), level);
    const std::size_t four_l = std::size_t{1} << (2 * level);
    EXPECT_EQ(m.vertices.size(), 4 * four_l + 2) << "level " << level;
    EXPECT_EQ(m.triangles.size(), 8 * four_l);
    for (const Vec3& v : m.vertices) EXPECT_NEAR(v.cwiseAbs().sum(), 1.0, kOnSurfaceTol);
    // No vertex twice, every edge shared by exactly two triangles (closed, manifold).
    std::set<std::array<double, 3>> unique;
    for (const Vec3& v : m.vertices) unique.insert({v.x(), v.y(), v.z()});
    EXPECT_EQ(unique.size(), m.vertices.size());
    std::set<std::pair<Index, Index>> directed;
    for (const auto& t : m.triangles)
      for (int e = 0; e < 3; ++e) directed.insert({t[e], t[(e + 1) % 3]});
    EXPECT_EQ(directed.size(), 3 * m.triangles.size()) << "consistent orientation";
    for (const auto& [a, b] : directed) EXPECT_TRUE(directed.count({b, a})) << "closed";
    expect_outward(m);
    EXPECT_NEAR(mesh_area(m), 4.0 * std::sqrt(3.0), 1e-12) << "area is preserved";
  }
  EXPECT_THROW(subdivide_4_1(octahedron_mesh(), -1), ParamError);
  EXPECT_THROW(subdivide_4_1(octahedron_mesh(), 13), ParamError);
}

TEST(Shapes, CubeMesh) {
  const TriangleMesh m = cube_mesh();
  EXPECT_EQ(m.vertices.size(), 8u);
  EXPECT_EQ(m.triangles.size(), 12u);
  for (const Vec3& v : m.vertices) EXPECT_EQ(v.cwiseAbs(), Vec3::Ones());
  expect_outward(m);
  EXPECT_NEAR(mesh_area(m), 24.0, 1e-12);
}

TEST(Shapes, MeshVertexNormals) {
  const SurfaceSamples s = mesh_vertices(octahedron_mesh());
  ASSERT_EQ(s.points.size(), 6u);
  // Four congruent faces around each vertex: the area-weighted normal is the vertex direction.
  for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR((s.normals[i] - s.points[i]).norm(), 0.0, kOnSurfaceTol);
  const SurfaceSamples c = mesh_vertices(cube_mesh());
  // The cube's corners touch one or two triangles of each face, so their normals are not the
  // diagonals, but they are unit vectors pointing outward into the corner's octant.
  for (std::size_t i = 0; i < 8; ++i) {
    EXPECT_NEAR(c.normals[i].norm(), 1.0, kOnSurfaceTol);
    EXPECT_GT(c.normals[i].cwiseProduct(c.points[i]).minCoeff(), 0.0);
  }
}

TEST(Shapes, SampleMeshLiesOnTheMeshWithFaceNormals) {
  const SurfaceSamples cube = sample_mesh(cube_mesh(), 12000, 3);
  ASSERT_EQ(cube.points.size(), 12000u);
  std::array<int, 6> per_face{};
  for (std::size_t i = 0; i < cube.points.size(); ++i) {
    const Vec3& p = cube.points[i];
    Eigen::Index axis = 0;
    p.cwiseAbs().maxCoeff(&axis);
    EXPECT_NEAR(std::abs(p[axis]), 1.0, kOnSurfaceTol);
    EXPECT_LE(p.cwiseAbs().maxCoeff(), 1.0 + kOnSurfaceTol);
    Vec3 expected = Vec3::Zero();
    expected[axis] = p[axis] > 0 ? 1.0 : -1.0;
    EXPECT_NEAR((cube.normals[i] - expected).norm(), 0.0, kOnSurfaceTol);
    ++per_face[static_cast<std::size_t>(2 * axis + (p[axis] > 0))];
  }
  // Area-uniform: 2000 per face; binomial sd ~41, allow 5 sd.
  for (const int n : per_face) EXPECT_NEAR(n, 2000, 205);

  const TriangleMesh oct = subdivide_4_1(octahedron_mesh(), 2);
  const SurfaceSamples o = sample_mesh(oct, 5000, 4);
  for (std::size_t i = 0; i < o.points.size(); ++i) {
    const Vec3& p = o.points[i];
    EXPECT_NEAR(p.cwiseAbs().sum(), 1.0, kOnSurfaceTol);
    const Vec3 signs(p.x() >= 0 ? 1 : -1, p.y() >= 0 ? 1 : -1, p.z() >= 0 ? 1 : -1);
    EXPECT_NEAR(std::abs(o.normals[i].dot(signs.normalized())), 1.0, 1e-12);
  }
  EXPECT_THROW(sample_mesh(TriangleMesh{}, 10, 1), ParamError);
}

TEST(Shapes, SamplersAreDeterministicBySeed) {
  const auto a = sample_mesh(cube_mesh(), 1000, 42);
  const auto b = sample_mesh(cube_mesh(), 1000, 42);
  const auto c = sample_mesh(cube_mesh(), 1000, 43);
  EXPECT_TRUE(test::bitwise_equal(a.points, b.points));
  EXPECT_TRUE(test::bitwise_equal(a.normals, b.normals));
  EXPECT_FALSE(test::bitwise_equal(a.points, c.points));
  EXPECT_TRUE(test::bitwise_equal(sample_sphere(500, 2.0, 5).points, sample_sphere(500, 2.0, 5).points));
  EXPECT_FALSE(test::bitwise_equal(sample_sphere(500, 2.0, 5).points, sample_sphere(500, 2.0, 6).points));
  EXPECT_TRUE(test::bitwise_equal(sample_cylinder(500, 1.0, 2.0, 5).points, sample_cylinder(500, 1.0, 2.0, 5).points));
}

TEST(Shapes, SphereAndCylinderSamples) {
  constexpr double radius = 2.5;
  const SurfaceSamples s = sample_sphere(20000, radius, 8);
  Vec3 mean = Vec3::Zero();
  int upper = 0;
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    EXPECT_NEAR(s.points[i].norm(), radius, kOnSurfaceTol * radius);
    EXPECT_NEAR((s.normals[i] - s.points[i] / radius).norm(), 0.0, kOnSurfaceTol);
    mean += s.normals[i];
    upper += s.points[i].z() > 0;
  }
  // Uniform on the sphere: mean of the unit vectors ~0 (sd 1/sqrt(3N) ~ 0.004 each).
  EXPECT_LT((mean / 20000.0).norm(), 0.03);
  EXPECT_NEAR(upper, 10000, 5 * 71);
  const SurfaceSamples c = sample_cylinder(10000, 1.5, 4.0, 9);
  double zmin = 0, zmax = 0;
  for (std::size_t i = 0; i < c.points.size(); ++i) {
    EXPECT_NEAR(c.points[i].head<2>().norm(), 1.5, kOnSurfaceTol);
    EXPECT_LE(std::abs(c.points[i].z()), 2.0);
    EXPECT_EQ(c.normals[i].z(), 0.0);
    EXPECT_NEAR((c.normals[i].head<2>() - c.points[i].head<2>() / 1.5).norm(), 0.0, kOnSurfaceTol);
    zmin = std::min(zmin, c.points[i].z());
    zmax = std::max(zmax, c.points[i].z());
  }
  EXPECT_LT(zmin, -1.9);
  EXPECT_GT(zmax, 1.9);
}

TEST(Shapes, NoiseStatisticsAndDeterminism) {
  constexpr double sigma = 0.02;
  constexpr std::size_t n = 40000;
  std::vector<Vec3> points(n, Vec3(1.0, -2.0, 3.0));
  add_noise(points, sigma, 17);
  Vec3 sum = Vec3::Zero(), sum2 = Vec3::Zero();
  double cross = 0.0;
  for (const Vec3& p : points) {
    const Vec3 d = p - Vec3(1.0, -2.0, 3.0);
    sum += d;
    sum2 += d.cwiseProduct(d);
    cross += d.x() * d.y();
  }
  const Vec3 mean = sum / static_cast<double>(n);
  // Standard error of the mean sigma / sqrt(n) = 1e-4; of the std ~ sigma / sqrt(2n) = 0.35%.
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(mean[a], 0.0, 5e-4);
    const double sd = std::sqrt(sum2[a] / static_cast<double>(n) - mean[a] * mean[a]);
    EXPECT_NEAR(sd / sigma, 1.0, 0.03) << "axis " << a;
  }
  EXPECT_NEAR(cross / static_cast<double>(n) / (sigma * sigma), 0.0, 0.03) << "independent axes";

  std::vector<Vec3> again(n, Vec3(1.0, -2.0, 3.0));
  add_noise(again, sigma, 17);
  EXPECT_TRUE(test::bitwise_equal(points, again));
  std::vector<Vec3> other(n, Vec3(1.0, -2.0, 3.0));
  add_noise(other, sigma, 18);
  EXPECT_FALSE(test::bitwise_equal(points, other));

  std::vector<Vec3> quiet(10, Vec3(1, 2, 3));
  add_noise(quiet, 0.0, 1);
  for (const Vec3& p : quiet) EXPECT_EQ(p, Vec3(1, 2, 3));
  EXPECT_THROW(add_noise(quiet, -0.1, 1), ParamError);
  EXPECT_THROW(add_noise(quiet, std::nan(""), 1), ParamError);
}

TEST(Shapes, BoundingBoxDiagonal) {
  EXPECT_EQ(bounding_box_diagonal(std::vector<Vec3>{}), 0.0);
  EXPECT_EQ(bounding_box_diagonal(std::vector<Vec3>{Vec3(1, 1, 1)}), 0.0);
  const std::vector<Vec3> box = {Vec3(0, 0, 0), Vec3(1, 2, 0), Vec3(0.5, 0, 2)};
  EXPECT_DOUBLE_EQ(bounding_box_diagonal(box), 3.0);
}

}  // namespace
}  // namespace pointfair
