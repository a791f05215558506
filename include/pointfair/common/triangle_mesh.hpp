#pragma once
// A triangle mesh as plain data, shared by the stages that make, read and measure against
// meshes: the test shapes (shapes/shapes.hpp), the mesh readers (io/mesh.hpp) and the exact
// distances (shapes/mesh_distance.hpp). Its own header, so that the formats at the edge do not
// depend on the test shapes.
#include <array>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair {

/// #V vertices and #T triangles, each three indices into `vertices`.
struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<Index, 3>> triangles;
};

}  // namespace pointfair
