#pragma once
// CGAL's point-set smoothers as peers of the quality benchmark (built only with libcgal-dev).
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair::quality {

/// jet_smooth_point_set with k neighbours (degree-2 jet), repeated `passes` times.
std::vector<Vec3> cgal_jet_smooth(const std::vector<Vec3>& points, int k, int passes);
/// bilateral_smooth_point_set (sharpness angle 25°) with k neighbours, `passes` times, with
/// normals from pca_estimate_normals and mst_orient_normals (k neighbours) before each pass.
std::vector<Vec3> cgal_bilateral_smooth(const std::vector<Vec3>& points, int k, int passes);

}  // namespace pointfair::quality
