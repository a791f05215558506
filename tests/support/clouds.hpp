#pragma once
// Shape makers for the core tests: configurations with known answers (rings, grids, planes,
// paraboloids) and small noisy clouds. All randomness comes from a seeded std::mt19937_64 and
// our own transforms, so every test sees the same cloud on every platform.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/LU>

#include "pointfair/shapes/shapes.hpp"
#include "pointfair/types.hpp"

namespace pointfair::test {

/// Uniform doubles in [0, 1) from the top 53 bits of a 64-bit Mersenne twister.
class Uniform {
 public:
  explicit Uniform(std::uint64_t seed) : engine_(seed) {}
  double operator()() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double in(double low, double high) { return low + (high - low) * (*this)(); }
  std::mt19937_64& engine() { return engine_; }

 private:
  std::mt19937_64 engine_;
};

/// `count` points uniform in the box [low, high]^3.
inline std::vector<Vec3> random_box(std::size_t count, double low, double high, std::uint64_t seed) {
  Uniform u(seed);
  std::vector<Vec3> points;
  points.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double x = u.in(low, high), y = u.in(low, high), z = u.in(low, high);
    points.emplace_back(x, y, z);
  }
  return points;
}

/// `count` points uniform in the square [-half, half]^2 of the plane z = 0.
inline std::vector<Vec3> random_plane(std::size_t count, double half, std::uint64_t seed) {
  Uniform u(seed);
  std::vector<Vec3> points;
  points.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double x = u.in(-half, half), y = u.in(-half, half);
    points.emplace_back(x, y, 0.0);
  }
  return points;
}

/// Paraboloid z = (a x^2 + c y^2) / 2.
struct Paraboloid {
  double a = 1.0;
  double c = 0.5;

  double height(double x, double y) const { return 0.5 * (a * x * x + c * y * y); }
  Vec3 at(double x, double y) const { return {x, y, height(x, y)}; }
  /// Upward unit normal.
  Vec3 normal(double x, double y) const { return Vec3(-a * x, -c * y, 1.0).normalized(); }
  /// Exact principal curvatures (k1 >= k2) w.r.t. the upward normal: eigenvalues of the shape
  /// operator I^-1 II of the graph.
  std::pair<double, double> curvatures(double x, double y) const {
    const double fx = a * x, fy = c * y;
    const double w = std::sqrt(1.0 + fx * fx + fy * fy);
    Eigen::Matrix2d first;
    first << 1.0 + fx * fx, fx * fy, fx * fy, 1.0 + fy * fy;
    Eigen::Matrix2d second;
    second << a / w, 0.0, 0.0, c / w;
    const Eigen::Matrix2d shape = first.inverse() * second;
    // Eigenvalues of a 2x2 (real: shape is similar to a symmetric matrix).
    const double half_trace = 0.5 * shape.trace();
    const double disc = std::sqrt(std::max(0.0, half_trace * half_trace - shape.determinant()));
    return {half_trace + disc, half_trace - disc};
  }
};

/// `count` points over [-half, half]^2 (uniform in x, y) on the paraboloid.
inline std::vector<Vec3> sample_paraboloid(const Paraboloid& f, std::size_t count, double half,
                                           std::uint64_t seed) {
  Uniform u(seed);
  std::vector<Vec3> points;
  points.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double x = u.in(-half, half), y = u.in(-half, half);
    points.push_back(f.at(x, y));
  }
  return points;
}

/// A regular ring of m points at tangential radius r around the apex of the paraboloid, the
/// first at angle `phase`; the apex (origin) is appended last.
inline std::vector<Vec3> paraboloid_ring(const Paraboloid& f, int m, double r, double phase = 0.0) {
  std::vector<Vec3> points;
  for (int j = 0; j < m; ++j) {
    const double theta = phase + 2.0 * std::numbers::pi * j / m;
    points.push_back(f.at(r * std::cos(theta), r * std::sin(theta)));
  }
  points.push_back(Vec3::Zero());
  return points;
}

/// A regular ring of m points at polar angle phi around the north pole (0, 0, R) of the sphere
/// of radius R; the pole is appended last.
inline std::vector<Vec3> sphere_ring(double radius, int m, double phi) {
  std::vector<Vec3> points;
  for (int j = 0; j < m; ++j) {
    const double theta = 2.0 * std::numbers::pi * j / m;
    points.emplace_back(radius * std::sin(phi) * std::cos(theta),
                        radius * std::sin(phi) * std::sin(theta), radius * std::cos(phi));
  }
  points.emplace_back(0.0, 0.0, radius);
  return points;
}

/// Integer grid points {0..n-1}^3 (many ties at equal distance), in a shuffled order.
inline std::vector<Vec3> integer_grid(int n, std::uint64_t seed) {
  std::vector<Vec3> points;
  for (int x = 0; x < n; ++x)
    for (int y = 0; y < n; ++y)
      for (int z = 0; z < n; ++z) points.emplace_back(x, y, z);
  std::shuffle(points.begin(), points.end(), std::mt19937_64(seed));
  return points;
}

/// Distance of p to the surface of the cube [-h, h]^3.
inline double cube_surface_distance(const Vec3& p, double h = 1.0) {
  const Vec3 q = p.cwiseAbs() - Vec3::Constant(h);
  const double outside = q.cwiseMax(0.0).norm();
  const double inside = std::min(q.maxCoeff(), 0.0);
  return std::abs(outside + inside);
}

/// Distance of p to the nearest edge of the cube [-h, h]^3 (as a set of 12 segments).
inline double cube_edge_distance(const Vec3& p, double h = 1.0) {
  double best = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (const double su : {-h, h})
      for (const double sv : {-h, h}) {
        const double along = std::clamp(p[axis], -h, h);
        Vec3 q;
        q[axis] = along;
        q[u] = su;
        q[v] = sv;
        best = std::min(best, (p - q).norm());
      }
  }
  return best;
}

/// A noisy area-uniform sample of the cube [-1, 1]^3: `count` points, isotropic Gaussian
/// noise of `noise_fraction` times the bounding-box diagonal of the clean sample.
inline std::vector<Vec3> noisy_cube(std::size_t count, double noise_fraction, std::uint64_t seed) {
  std::vector<Vec3> points = sample_mesh(cube_mesh(), count, seed).points;
  add_noise(points, noise_fraction * bounding_box_diagonal(points), seed + 1);
  return points;
}

/// A scan-like scene: a ground square [-half, half]^2 at z = 0 sampled on a jittered grid of
/// `spacing` (metres), with a box of footprint [-box_half, box_half]^2 and height `box_height`
/// standing on it (its four walls and its roof sampled at the same spacing; the ground under
/// it left out), every point moved by isotropic Gaussian noise of `sigma`. `clean` holds each
/// point's position before the noise, `ground` whether it is a ground point.
struct GroundWithBox {
  std::vector<Vec3> points, clean;
  std::vector<char> ground;
};
inline GroundWithBox ground_with_box(double half, double spacing, double box_half, double box_height, double sigma,
                                     std::uint64_t seed) {
  GroundWithBox scene;
  Uniform u(seed);
  const auto jitter = [&] { return u.in(-0.25, 0.25) * spacing; };
  const auto add = [&](const Vec3& p, bool ground) {
    scene.clean.push_back(p);
    scene.ground.push_back(ground ? 1 : 0);
  };
  const int cells = static_cast<int>(std::lround(2.0 * half / spacing));
  for (int i = 0; i < cells; ++i)
    for (int j = 0; j < cells; ++j) {
      const double x = -half + (i + 0.5) * spacing + jitter(), y = -half + (j + 0.5) * spacing + jitter();
      if (std::abs(x) < box_half && std::abs(y) < box_half) continue;
      add(Vec3(x, y, 0.0), true);
    }
  const int across = static_cast<int>(std::lround(2.0 * box_half / spacing));
  const int up = static_cast<int>(std::lround(box_height / spacing));
  for (int i = 0; i < across; ++i) {
    for (int j = 0; j < across; ++j)
      add(Vec3(-box_half + (i + 0.5) * spacing + jitter(), -box_half + (j + 0.5) * spacing + jitter(), box_height),
          false);
    for (int h = 0; h < up; ++h) {
      const double a = -box_half + (i + 0.5) * spacing + jitter(), z = (h + 0.5) * box_height / up;
      add(Vec3(a, -box_half, z), false);
      add(Vec3(box_half, a, z), false);
      add(Vec3(-a, box_half, z), false);
      add(Vec3(-box_half, -a, z), false);
    }
  }
  scene.points = scene.clean;
  const auto gauss = [&] {  // Box-Muller: the same numbers on every platform
    const double radius = std::sqrt(-2.0 * std::log(1.0 - u())), angle = 2.0 * std::numbers::pi * u();
    return sigma * radius * std::cos(angle);
  };
  for (Vec3& p : scene.points) {
    const double x = gauss(), y = gauss(), z = gauss();
    p += Vec3(x, y, z);
  }
  return scene;
}

}  // namespace pointfair::test
