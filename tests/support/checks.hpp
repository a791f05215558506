#pragma once
// Small comparison helpers shared by the core tests.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <span>
#include <vector>

#include "pointfair/neighbors/neighborhoods.hpp"
#include "pointfair/types.hpp"

namespace pointfair::test {

/// The neighbour lists as nested vectors (row r: the first counts[r] slots).
inline std::vector<std::vector<Index>> rows_of(const Neighborhoods& n) {
  std::vector<std::vector<Index>> rows(n.size());
  for (std::size_t i = 0; i < n.size(); ++i) {
    const auto row = n.of(i);
    rows[i].assign(row.begin(), row.end());
  }
  return rows;
}

/// True if both arrays hold the same bytes (same size, memcmp equal).
template <class T>
bool bitwise_equal(std::span<const T> a, std::span<const T> b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size_bytes()) == 0);
}
template <class T>
bool bitwise_equal(const std::vector<T>& a, const std::vector<T>& b) {
  return bitwise_equal(std::span<const T>(a), std::span<const T>(b));
}

/// RMS distance of the points to the unit sphere about the origin.
inline double unit_sphere_rms(std::span<const Vec3> points) {
  double sum = 0.0;
  for (const Vec3& p : points) sum += (p.norm() - 1.0) * (p.norm() - 1.0);
  return points.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(points.size()));
}

/// Largest |a_i - b_i| over two equally long position arrays.
inline double max_distance(std::span<const Vec3> a, std::span<const Vec3> b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) worst = std::max(worst, (a[i] - b[i]).norm());
  return worst;
}

/// Only the used slots of two neighbourhood sets agree (stride, counts and lists).
inline bool same_neighborhoods(const Neighborhoods& a, const Neighborhoods& b) {
  return a.stride == b.stride && a.counts == b.counts && rows_of(a) == rows_of(b);
}

}  // namespace pointfair::test
