#pragma once
// Plain data types shared by every stage.
#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace pointfair {

/// A point or a vector in R^3. Positions are kept as a flat std::vector<Vec3>
/// (24 bytes a point, no padding), so a cloud can be viewed as an N-by-3 array.
using Vec3 = Eigen::Vector3d;

/// Index of a point in a position array. 32 bits: one in-core array holds at most 2^32-1
/// points; larger scans are processed in tiles.
using Index = std::uint32_t;

}  // namespace pointfair
