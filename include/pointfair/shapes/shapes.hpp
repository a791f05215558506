#pragma once
// Test shapes of Lange & Polthier (2005), Section 5, and samples of them: the 4-1 subdivided
// octahedron, cubes, spheres, cylinders, and area-uniform samples of any triangle mesh, plus
// the paper's "normal and tangential" noise. Random numbers come from a seeded 64-bit
// Mersenne twister with our own uniform and Gaussian transforms, so a seed gives the same
// cloud on every platform.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "pointfair/common/triangle_mesh.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

/// Points with a unit normal each (the true surface normal where the shape has one).
struct SurfaceSamples {
  std::vector<Vec3> points;
  std::vector<Vec3> normals;
};

/// The regular octahedron with vertices at ±1 on each axis, outward-oriented triangles.
TriangleMesh octahedron_mesh();
/// The axis-aligned cube [-1, 1]^3 as 12 outward-oriented triangles.
TriangleMesh cube_mesh();
/// `levels` regular 4-1 subdivisions (each triangle split into four at edge midpoints).
TriangleMesh subdivide_4_1(const TriangleMesh& mesh, int levels);

/// The mesh's vertices with area-weighted vertex normals.
SurfaceSamples mesh_vertices(const TriangleMesh& mesh);
/// `count` area-uniform random points on the mesh, each with its face's normal.
SurfaceSamples sample_mesh(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed);
/// `count` uniform random points on the sphere of `radius` about the origin.
SurfaceSamples sample_sphere(std::size_t count, double radius, std::uint64_t seed);
/// `count` uniform random points on the side of the cylinder x^2 + y^2 = radius^2,
/// |z| <= height / 2.
SurfaceSamples sample_cylinder(std::size_t count, double radius, double height, std::uint64_t seed);

/// The truncated octahedron: vertices all permutations of (0, ±1, ±2); 8 regular hexagons
/// (normals (±1, ±1, ±1)/sqrt 3) and 6 squares (normals ±e_i), each split into triangles,
/// outward-oriented. Dihedral angles 109.47° (hexagon-square) and 125.26° (hexagon-hexagon).
TriangleMesh truncated_octahedron_mesh();
/// `count` area-uniform random points on the torus with tube radius `minor` about the circle of
/// radius `major` in the xy-plane (z the axis), with outward normals.
SurfaceSamples sample_torus(std::size_t count, double major, double minor, std::uint64_t seed);
/// `count` area-uniform random points on the union of two surfaces (the paper's Figure 2): the
/// cylinder y^2 + z^2 = radius^2, |x| <= length / 2 (outward normals), and the plane z = 0,
/// |x| <= length / 2, |y| <= width / 2 (normal +z), which cuts it along the lines
/// y = ±radius, z = 0.
SurfaceSamples sample_cylinder_plane(std::size_t count, double radius, double length,
                                     double width, std::uint64_t seed);
/// Enneper's minimal surface x(u, v) = (u - u^3/3 + u v^2, v - v^3/3 + v u^2, u^2 - v^2) and
/// its unit normal (x_u × x_v normalised). Principal curvatures ±2 / (1 + u^2 + v^2)^2.
Vec3 enneper_point(double u, double v);
Vec3 enneper_normal(double u, double v);
/// `count` area-uniform random points of Enneper's surface over the parameter disc
/// u^2 + v^2 <= extent^2 (embedded for extent < sqrt 3).
SurfaceSamples sample_enneper(std::size_t count, double extent, std::uint64_t seed);

/// Adds Gaussian noise with standard deviation `sigma` (length) along the normal and along
/// both tangent directions: an isotropic 3-D Gaussian, since the three directions are
/// orthonormal and share one sigma.
void add_noise(std::vector<Vec3>& points, double sigma, std::uint64_t seed);

/// Length of the diagonal of the axis-aligned bounding box (0 for an empty cloud).
double bounding_box_diagonal(std::span<const Vec3> points);

}  // namespace pointfair
