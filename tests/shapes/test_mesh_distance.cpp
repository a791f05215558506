// Point-to-triangle, point-to-segment and point-to-mesh distances against a plain reference
// (projection onto the plane if it falls inside, otherwise the nearest of the three edges).
#include "pointfair/shapes/mesh_distance.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "support/clouds.hpp"

namespace pointfair {
namespace {

// A handful of flops on unit-size inputs.
constexpr double kTol = 1e-12;

double ref_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  double t = (p - a).dot(ab) / ab.squaredNorm();
  t = std::min(1.0, std::max(0.0, t));
  return (p - a - t * ab).norm();
}

double ref_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a).normalized();
  const Vec3 q = p - n.dot(p - a) * n;  // projection onto the plane
  // Inside if q is on the inner side of all three edges.
  const bool inside = (b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 &&
                      (a - c).cross(q - c).dot(n) >= 0;
  if (inside) return (p - q).norm();
  return std::min({ref_segment(p, a, b), ref_segment(p, b, c), ref_segment(p, c, a)});
}

TEST(MeshDistance, TriangleMatchesReference) {
  test::Uniform u(1);
  for (int trial = 0; trial < 2000; ++trial) {
    const Vec3 a(u.in(-1, 1), u.in(-1, 1), u.in(-1, 1));
    const Vec3 b(u.in(-1, 1), u.in(-1, 1), u.in(-1, 1));
    const Vec3 c(u.in(-1, 1), u.in(-1, 1), u.in(-1, 1));
    if ((b - a).cross(c - a).norm() < 1e-3) continue;  // nearly degenerate
    const Vec3 p(u.in(-2, 2), u.in(-2, 2), u.in(-2, 2));
    const Vec3 q = closest_point_on_triangle(p, a, b, c);
    EXPECT_NEAR((p - q).norm(), ref_triangle(p, a, b, c), kTol) << trial;
    // q lies in the triangle: its barycentric coordinates are in [0, 1].
    const Vec3 n = (b - a).cross(c - a);
    EXPECT_NEAR(n.normalized().dot(q - a), 0.0, kTol);
    EXPECT_GE((b - a).cross(q - a).dot(n), -kTol);
    EXPECT_GE((c - b).cross(q - b).dot(n), -kTol);
    EXPECT_GE((a - c).cross(q - c).dot(n), -kTol);
  }
}

TEST(MeshDistance, SegmentAndMesh) {
  EXPECT_DOUBLE_EQ(distance_to_segment(Vec3(0.5, 1, 0), Vec3(0, 0, 0), Vec3(1, 0, 0)), 1.0);
  EXPECT_DOUBLE_EQ(distance_to_segment(Vec3(3, 4, 0), Vec3(0, 0, 0), Vec3(0, 0, 0)), 5.0);
  EXPECT_DOUBLE_EQ(distance_to_segment(Vec3(-3, 4, 0), Vec3(0, 0, 0), Vec3(1, 0, 0)), 5.0);
  const TriangleMesh cube = cube_mesh();
  test::Uniform u(2);
  for (int i = 0; i < 500; ++i) {
    const Vec3 p(u.in(-2, 2), u.in(-2, 2), u.in(-2, 2));
    EXPECT_NEAR(distance_to_mesh(p, cube), test::cube_surface_distance(p), kTol);
  }
}

}  // namespace
}  // namespace pointfair
