#pragma once
// Exact distances from points to triangles and segments, for measuring results against a
// ground-truth mesh (brute force over the triangles: meant for small meshes such as the
// paper's polytopes).
#include <span>

#include "pointfair/common/triangle_mesh.hpp"

namespace pointfair {

/// The point of triangle (a, b, c) closest to p.
Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);
/// Distance from p to the segment [a, b].
double distance_to_segment(const Vec3& p, const Vec3& a, const Vec3& b);
/// Distance from p to the nearest triangle of `mesh` (brute force).
double distance_to_mesh(const Vec3& p, const TriangleMesh& mesh);

}  // namespace pointfair
