#include "pointfair/shapes.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <utility>

#include <Eigen/Geometry>

#include "pointfair/params_error.hpp"

namespace pointfair {
namespace {

// Uniform in [0, 1) from the top 53 bits: the same on every platform.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  // Box-Muller, both values used.
  double gaussian() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u = 0.0;
    while (u <= 0.0) u = uniform();
    const double v = uniform();
    const double r = std::sqrt(-2.0 * std::log(u));
    spare_ = r * std::sin(2.0 * std::numbers::pi * v);
    has_spare_ = true;
    return r * std::cos(2.0 * std::numbers::pi * v);
  }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

Vec3 triangle_normal(const TriangleMesh& m, const std::array<Index, 3>& t) {
  return (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
}

}  // namespace

TriangleMesh octahedron_mesh() {
  TriangleMesh m;
  m.vertices = {Vec3(1, 0, 0), Vec3(-1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1), Vec3(0, 0, -1)};
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  return m;
}

TriangleMesh cube_mesh() {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
  // Each face as two triangles, counter-clockwise seen from outside.
  const std::array<std::array<Index, 4>, 6> faces = {{{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                                      {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}}};
  for (const auto& f : faces) {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}

TriangleMesh subdivide_4_1(const TriangleMesh& mesh, int levels) {
  require(levels >= 0 && levels <= 12, "subdivision levels must be in 0..12");
  TriangleMesh m = mesh;
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<Index, Index>, Index> midpoints;
    auto midpoint = [&](Index a, Index b) {
      const auto key = std::minmax(a, b);
      const auto [it, inserted] = midpoints.try_emplace({key.first, key.second}, static_cast<Index>(m.vertices.size()));
      if (inserted) m.vertices.push_back(0.5 * (m.vertices[a] + m.vertices[b]));
      return it->second;
    };
    std::vector<std::array<Index, 3>> next;
    next.reserve(m.triangles.size() * 4);
    for (const auto& t : m.triangles) {
      const Index ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
      next.push_back({t[0], ab, ca});
      next.push_back({ab, t[1], bc});
      next.push_back({ca, bc, t[2]});
      next.push_back({ab, bc, ca});
    }
    m.triangles = std::move(next);
  }
  return m;
}

SurfaceSamples mesh_vertices(const TriangleMesh& mesh) {
  SurfaceSamples s;
  s.points = mesh.vertices;
  s.normals.assign(mesh.vertices.size(), Vec3::Zero());
  for (const auto& t : mesh.triangles) {
    const Vec3 n = triangle_normal(mesh, t);  // length = twice the area
    for (const Index v : t) s.normals[v] += n;
  }
  for (auto& n : s.normals) n = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(Vec3::UnitZ());
  return s;
}

SurfaceSamples sample_mesh(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed) {
  require(!mesh.triangles.empty(), "cannot sample a mesh without triangles");
  std::vector<double> cumulative;
  cumulative.reserve(mesh.triangles.size());
  double total = 0.0;
  for (const auto& t : mesh.triangles) {
    total += triangle_normal(mesh, t).norm();
    cumulative.push_back(total);
  }
  require(total > 0.0, "cannot sample a mesh of zero area");
  Random random(seed);
  SurfaceSamples s;
  s.points.reserve(count);
  s.normals.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double pick = random.uniform() * total;
    auto it = std::upper_bound(cumulative.begin(), cumulative.end(), pick);
    if (it == cumulative.end()) --it;
    const auto& t = mesh.triangles[static_cast<std::size_t>(it - cumulative.begin())];
    double u = random.uniform(), v = random.uniform();
    if (u + v > 1.0) {
      u = 1.0 - u;
      v = 1.0 - v;
    }
    const Vec3& a = mesh.vertices[t[0]];
    s.points.push_back(a + u * (mesh.vertices[t[1]] - a) + v * (mesh.vertices[t[2]] - a));
    s.normals.push_back(triangle_normal(mesh, t).normalized());
  }
  return s;
}

SurfaceSamples sample_sphere(std::size_t count, double radius, std::uint64_t seed) {
  Random random(seed);
  SurfaceSamples s;
  s.points.reserve(count);
  s.normals.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double z = 2.0 * random.uniform() - 1.0;
    const double phi = 2.0 * std::numbers::pi * random.uniform();
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Vec3 n(r * std::cos(phi), r * std::sin(phi), z);
    s.normals.push_back(n);
    s.points.push_back(radius * n);
  }
  return s;
}

SurfaceSamples sample_cylinder(std::size_t count, double radius, double height, std::uint64_t seed) {
  Random random(seed);
  SurfaceSamples s;
  s.points.reserve(count);
  s.normals.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double phi = 2.0 * std::numbers::pi * random.uniform();
    const double z = (random.uniform() - 0.5) * height;
    const Vec3 n(std::cos(phi), std::sin(phi), 0.0);
    s.normals.push_back(n);
    s.points.push_back(Vec3(radius * n.x(), radius * n.y(), z));
  }
  return s;
}

void add_noise(std::vector<Vec3>& points, double sigma, std::uint64_t seed) {
  require(sigma >= 0.0 && std::isfinite(sigma), "noise sigma must be >= 0");
  Random random(seed);
  for (auto& p : points) {
    const double x = random.gaussian(), y = random.gaussian(), z = random.gaussian();
    p += sigma * Vec3(x, y, z);
  }
}

double bounding_box_diagonal(std::span<const Vec3> points) {
  if (points.empty()) return 0.0;
  Eigen::AlignedBox3d box;
  for (const auto& p : points) box.extend(p);
  return box.diagonal().norm();
}

}  // namespace pointfair
