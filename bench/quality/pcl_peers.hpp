#pragma once
// PCL's moving least squares as a peer of the quality benchmark (built only with libpcl-dev
// and -DPOINTFAIR_QUALITY_PCL=ON).
#include <cstddef>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair::quality {

/// pcl::MovingLeastSquares (PCL 1.13) projecting each input point onto a polynomial of
/// `order` (2: a quadric height field) fitted to its neighbours within `radius` (length;
/// Gaussian weight of width `radius`, PCL's default), projection SIMPLE, no upsampling.
struct PclMlsResult {
  /// One point per input point, in input order (PCL's output is placed by its corresponding
  /// input indices, since its threads and dropped points change the order). A point PCL did
  /// not output (fewer than 3 neighbours within the radius) keeps its input position.
  std::vector<Vec3> points;
  /// How many input points PCL did not output.
  std::size_t kept_input = 0;
};
PclMlsResult pcl_mls_project(const std::vector<Vec3>& points, double radius, int order, int threads);

}  // namespace pointfair::quality
