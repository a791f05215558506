#include "pointfair/shapes/shapes.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <utility>

#include <Eigen/Geometry>

#include "pointfair/common/params_error.hpp"

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

// ---- Further test shapes of Section 5 (truncated octahedron, torus, cylinder ∩ plane) and a
// minimal surface (Enneper's, in place of the paper's Costa surface, whose Weierstrass data
// need elliptic functions).
namespace pointfair {

TriangleMesh truncated_octahedron_mesh() {
  TriangleMesh m;
  // All permutations of (0, ±1, ±2).
  const std::array<std::array<int, 3>, 6> perms = {{{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  for (const auto& perm : perms) {
    for (const int s1 : {-1, 1}) {
      for (const int s2 : {-1, 1}) {
        const std::array<double, 3> value = {0.0, 1.0 * s1, 2.0 * s2};
        Vec3 v;
        for (int c = 0; c < 3; ++c) v[perm[static_cast<std::size_t>(c)]] = value[static_cast<std::size_t>(c)];
        m.vertices.push_back(v);
      }
    }
  }
  // Faces: the planes n . x = d with n in {±e_i} (d = 2) and (±1, ±1, ±1) (d = 3).
  std::vector<Vec3> normals;
  for (int c = 0; c < 3; ++c)
    for (const int s : {-1, 1}) {
      Vec3 n = Vec3::Zero();
      n[c] = s;
      normals.push_back(n);
    }
  for (int i = 0; i < 8; ++i) normals.emplace_back(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
  for (const Vec3& n : normals) {
    double d = -1e300;
    for (const Vec3& v : m.vertices) d = std::max(d, n.dot(v));
    std::vector<Index> face;
    Vec3 centre = Vec3::Zero();
    for (std::size_t i = 0; i < m.vertices.size(); ++i)
      if (std::abs(n.dot(m.vertices[i]) - d) < 1e-9) {
        face.push_back(static_cast<Index>(i));
        centre += m.vertices[i];
      }
    centre /= static_cast<double>(face.size());
    const Vec3 u = (m.vertices[face[0]] - centre).normalized();
    const Vec3 w = n.normalized().cross(u);
    std::sort(face.begin(), face.end(), [&](Index a, Index b) {
      const Vec3 da = m.vertices[a] - centre, db = m.vertices[b] - centre;
      return std::atan2(da.dot(w), da.dot(u)) < std::atan2(db.dot(w), db.dot(u));
    });
    for (std::size_t k = 1; k + 1 < face.size(); ++k) m.triangles.push_back({face[0], face[k], face[k + 1]});
  }
  return m;
}

SurfaceSamples sample_torus(std::size_t count, double major, double minor, std::uint64_t seed) {
  require(major > minor && minor > 0.0, "torus radii must satisfy major > minor > 0");
  Random random(seed);
  SurfaceSamples s;
  s.points.reserve(count);
  s.normals.reserve(count);
  while (s.points.size() < count) {
    const double u = 2.0 * std::numbers::pi * random.uniform();
    const double v = 2.0 * std::numbers::pi * random.uniform();
    // The area element is proportional to major + minor cos v: accept by rejection.
    if (random.uniform() * (major + minor) > major + minor * std::cos(v)) continue;
    const Vec3 n(std::cos(v) * std::cos(u), std::cos(v) * std::sin(u), std::sin(v));
    s.normals.push_back(n);
    s.points.push_back(Vec3(major * std::cos(u), major * std::sin(u), 0.0) + minor * n);
  }
  return s;
}

SurfaceSamples sample_cylinder_plane(std::size_t count, double radius, double length, double width,
                                     std::uint64_t seed) {
  require(radius > 0.0 && length > 0.0 && width > 0.0, "cylinder-plane sizes must be > 0");
  Random random(seed);
  const double cylinder_area = 2.0 * std::numbers::pi * radius * length;
  const double plane_area = length * width;
  SurfaceSamples s;
  s.points.reserve(count);
  s.normals.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double pick = random.uniform() * (cylinder_area + plane_area);
    const double x = (random.uniform() - 0.5) * length;
    if (pick < cylinder_area) {
      const double phi = 2.0 * std::numbers::pi * random.uniform();
      const Vec3 n(0.0, std::cos(phi), std::sin(phi));
      s.normals.push_back(n);
      s.points.push_back(Vec3(x, radius * n.y(), radius * n.z()));
    } else {
      const double y = (random.uniform() - 0.5) * width;
      s.normals.push_back(Vec3::UnitZ());
      s.points.push_back(Vec3(x, y, 0.0));
    }
  }
  return s;
}

Vec3 enneper_point(double u, double v) {
  return {u - u * u * u / 3.0 + u * v * v, v - v * v * v / 3.0 + v * u * u, u * u - v * v};
}

Vec3 enneper_normal(double u, double v) {
  const Vec3 xu(1.0 - u * u + v * v, 2.0 * u * v, 2.0 * u);
  const Vec3 xv(2.0 * u * v, 1.0 - v * v + u * u, -2.0 * v);
  return xu.cross(xv).normalized();
}

SurfaceSamples sample_enneper(std::size_t count, double extent, std::uint64_t seed) {
  require(extent > 0.0 && extent < std::sqrt(3.0), "Enneper extent must be in (0, sqrt 3)");
  Random random(seed);
  SurfaceSamples s;
  s.points.reserve(count);
  s.normals.reserve(count);
  const double max_element = (1.0 + extent * extent) * (1.0 + extent * extent);
  while (s.points.size() < count) {
    const double u = (2.0 * random.uniform() - 1.0) * extent;
    const double v = (2.0 * random.uniform() - 1.0) * extent;
    const double r2 = u * u + v * v;
    if (r2 > extent * extent) continue;
    // Area element (1 + u^2 + v^2)^2 du dv.
    if (random.uniform() * max_element > (1.0 + r2) * (1.0 + r2)) continue;
    s.points.push_back(enneper_point(u, v));
    s.normals.push_back(enneper_normal(u, v));
  }
  return s;
}

}  // namespace pointfair
