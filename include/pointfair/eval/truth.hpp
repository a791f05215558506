#pragma once
// Ground truth for measuring results: the true surface of a generated test shape (analytic
// where it can be: sphere, torus, cylinder ∩ plane, Enneper's surface; exact triangle meshes
// for the polytopes) or a triangle mesh read from a file, answering "closest true point".
//
// A truth file is a small text file naming the shape and its parameters, one "key value"
// line each, after a first line "pointfair-truth 1":
//   shape torus            cube | octahedron | truncated-octahedron | sphere | torus |
//                          cylinder-plane | enneper | mesh
//   radius 1               sphere and cylinder-plane radius
//   major 1  minor 0.4     torus radii
//   length 4  width 4      cylinder-plane extent along x and the plane's extent along y
//   extent 1.2             Enneper parameter-disc radius
//   mesh fandisk.off       mesh file, relative to the truth file's folder or absolute
#include <filesystem>
#include <limits>
#include <memory>
#include <string>

#include "pointfair/shapes/shapes.hpp"

namespace pointfair::eval {

struct TruthSpec {
  std::string shape = "sphere";
  double radius = 1.0;
  double major = 1.0;
  double minor = 0.4;
  double length = 4.0;
  double width = 4.0;
  double extent = 1.2;
  std::filesystem::path mesh;
};

/// Reads a truth file. Throws io::IoError "<file>: <problem>".
TruthSpec read_truth_file(const std::filesystem::path& file);
/// Writes a truth file atomically; a mesh path is written as given (make it absolute or
/// relative to the truth file's folder).
void write_truth_file(const std::filesystem::path& file, const TruthSpec& spec);
/// A truth file (.truth), a mesh file (.off, .ply) or a bare shape name.
TruthSpec truth_from_argument(const std::string& argument);

/// The closest point of the true surface to a query point.
struct SurfacePoint {
  Vec3 point = Vec3::Zero();
  /// Unit normal there (outward for closed surfaces; a fixed orientation for open ones).
  Vec3 normal = Vec3::UnitZ();
  /// Distance to the surface, positive on the side the normal points to.
  double signed_distance = 0.0;
  /// Distance from `point` to the nearest sharp crease (mesh edge with a dihedral angle above
  /// the sharp angle, or the analytic intersection line); +inf without creases.
  double crease_distance = std::numeric_limits<double>::infinity();
  /// True principal curvatures k1 >= k2 at `point`, signed as compute_attributes reports
  /// them: positive where the surface is convex with respect to `normal` (a sphere of
  /// radius R with outward normals has +1/R). Valid when has_curvature.
  double k1 = 0.0;
  double k2 = 0.0;
  bool has_curvature = false;
};

struct TruthParams {
  /// A mesh edge is a sharp crease when the normals of its faces differ by more than this
  /// (degrees).
  double sharp_angle_degrees = 30.0;
};

class GroundTruth {
 public:
  /// Builds the truth (loading a mesh file, indexing triangles and sharp edges).
  /// Throws ParamError for an unknown shape or bad parameters, io::IoError for the mesh file.
  explicit GroundTruth(const TruthSpec& spec, const TruthParams& params = {});
  ~GroundTruth();
  GroundTruth(GroundTruth&&) noexcept;
  GroundTruth& operator=(GroundTruth&&) noexcept;

  /// The closest true point to p. Thread-safe.
  SurfacePoint closest(const Vec3& p) const;
  /// Whether the surface has sharp creases (feature recall is defined).
  bool has_creases() const;
  /// Axis-aligned bounds of the true surface.
  Eigen::AlignedBox3d bounds() const;
  /// `count` area-uniform samples of the true surface (reference cloud for Chamfer distances).
  SurfaceSamples sample(std::size_t count, std::uint64_t seed) const;
  /// Name and parameters, for reports.
  const TruthSpec& spec() const;
  /// The triangle mesh when the truth is one (polytopes, mesh files), else nullptr.
  const TriangleMesh* mesh() const;
  /// Number of sharp mesh edges (0 for analytic truths).
  std::size_t sharp_edge_count() const;

  /// Generic interface of one kind of truth (internal).
  struct Surface;

 private:
  std::unique_ptr<Surface> surface_;
};

/// The shapes `pointfair generate` knows, with default sizes. `mesh` is read for "mesh".
/// Samples count points of the clean surface (the octahedron: vertices of the 4-1 subdivision
/// level nearest to count).
SurfaceSamples generate_clean_samples(const TruthSpec& spec, std::size_t count, std::uint64_t seed);

}  // namespace pointfair::eval
