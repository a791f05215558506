// The shapes added for the quality benchmark (truncated octahedron, torus, cylinder ∩ plane,
// Enneper's surface).
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "pointfair/shapes/shapes.hpp"

namespace pointfair {
namespace {

TEST(ShapesExtra, TruncatedOctahedronFacesAreOutwardAndPlanar) {
  const TriangleMesh m = truncated_octahedron_mesh();
  double area = 0;
  for (const auto& t : m.triangles) {
    const Vec3 n = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
    EXPECT_GT(n.dot(m.vertices[t[0]]), 0.0);  // outward: the origin is inside
    area += 0.5 * n.norm();
  }
  // Edge length sqrt 2: area (6 + 12 sqrt 3) a^2.
  EXPECT_NEAR(area, (6 + 12 * std::sqrt(3.0)) * 2.0, 1e-9);
}

TEST(ShapesExtra, TorusSamplesSatisfyTheImplicitEquation) {
  const SurfaceSamples s = sample_torus(2000, 1.0, 0.3, 5);
  double outer = 0;
  for (const Vec3& p : s.points) {
    const double ring = std::hypot(p.x(), p.y()) - 1.0;
    EXPECT_NEAR(ring * ring + p.z() * p.z(), 0.09, 1e-12);
    outer += ring > 0 ? 1 : 0;
  }
  // Area-uniform: the outer half (ring > 0) holds (pi + 2 r) / (2 pi) of the area.
  EXPECT_NEAR(outer / 2000.0, (std::numbers::pi + 0.6) / (2 * std::numbers::pi), 0.03);
}

TEST(ShapesExtra, CylinderPlaneSplitsByArea) {
  const SurfaceSamples s = sample_cylinder_plane(4000, 1.0, 4.0, 4.0, 6);
  std::size_t plane = 0;
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    if (s.normals[i] == Vec3::UnitZ() && s.points[i].z() == 0.0) ++plane;
    else EXPECT_NEAR(std::hypot(s.points[i].y(), s.points[i].z()), 1.0, 1e-12);
  }
  EXPECT_NEAR(static_cast<double>(plane) / 4000.0, 16.0 / (16.0 + 8 * std::numbers::pi), 0.03);
}

TEST(ShapesExtra, EnneperNormalIsOrthogonalToTangents) {
  const double u = 0.4, v = 0.7, h = 1e-6;
  const Vec3 n = enneper_normal(u, v);
  const Vec3 xu = (enneper_point(u + h, v) - enneper_point(u - h, v)) / (2 * h);
  const Vec3 xv = (enneper_point(u, v + h) - enneper_point(u, v - h)) / (2 * h);
  EXPECT_NEAR(n.dot(xu), 0.0, 1e-8);
  EXPECT_NEAR(n.dot(xv), 0.0, 1e-8);
  EXPECT_EQ(sample_enneper(100, 1.2, 1).points.size(), 100u);
}

}  // namespace
}  // namespace pointfair
