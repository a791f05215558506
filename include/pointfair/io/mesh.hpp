#pragma once
// Triangle meshes from files: ground truth for measuring results and a source of area-uniform
// samples. Polygons with more than three corners are split into a fan of triangles.
#include <filesystem>

#include "pointfair/common/triangle_mesh.hpp"
#include "pointfair/io/point_table.hpp"

namespace pointfair::io {

/// Reads an OFF file ("OFF" header, optionally "COFF"/"NOFF"... variants are refused; counts
/// line "V F E"; V lines "x y z ..."; F lines "n i1 ... in ..."). '#' starts a comment.
/// Throws IoError "<file>: <problem>" for a malformed header or body, an index out of range,
/// a face with fewer than three corners or a non-finite coordinate.
TriangleMesh read_off_mesh(const std::filesystem::path& file);

/// Reads the "vertex" (x, y, z) and "face" (list "vertex_indices" or "vertex_index") elements
/// of a PLY file, ascii or binary of either byte order. Other elements are skipped.
/// Throws IoError as read_off_mesh, and for a PLY file without faces.
TriangleMesh read_ply_mesh(const std::filesystem::path& file);

/// read_off_mesh for .off, read_ply_mesh for .ply (case-insensitive).
/// Throws IoError "<file>: unknown mesh extension" otherwise.
TriangleMesh read_mesh(const std::filesystem::path& file);

/// Writes an ASCII OFF file atomically (shortest round-trip numbers).
void write_off_mesh(const std::filesystem::path& file, const TriangleMesh& mesh);

}  // namespace pointfair::io
