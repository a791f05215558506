#pragma once
// MeshLab's MLS projections as peers of the quality benchmark, run through meshlabserver
// (MeshLab 2020.09, Debian's `meshlab`) under xvfb-run: found on the PATH at run time, so
// nothing is linked and a build without MeshLab runs the other peers.
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair::quality {

/// Whether `meshlabserver` and `xvfb-run` are both on the PATH.
bool meshlab_available();

enum class MeshlabMls { Rimls, Apss };

/// One run: "Compute normals for point sets" (`normal_k` neighbours, no smoothing
/// iterations, MeshLab's own orientation), then "MLS projection (RIMLS)" or "(APSS)" of the
/// cloud onto the surface it defines, MeshLab's defaults for the rest (projection accuracy
/// 1e-4, 15 projection iterations, RIMLS: 3 refitting iterations).
struct MeshlabMlsParams {
  MeshlabMls variant = MeshlabMls::Rimls;
  int normal_k = 32;
  /// "MLS - Filter scale": the kernel's support in multiples of each point's local spacing.
  double filter_scale = 4.0;
  /// RIMLS "MLS - Sharpness" (SigmaN): width of the normal weight, 0.5 sharp to 2 smooth.
  double sigma_n = 0.75;
  /// APSS "MLS - Spherical parameter": 0 fits planes, 1 spheres.
  double spherical = 1.0;
};

struct MeshlabResult {
  /// One point per input point, in input order. Each point goes to MeshLab carrying its
  /// index as the vertex quality and is placed back by it; a point MeshLab did not return
  /// keeps its input position, as does a point whose projection failed (MeshLab writes NaN).
  std::vector<Vec3> points;
  /// Points MeshLab returned at another index than their own; points it did not return or
  /// returned as NaN (both kept their input position); of those, the NaN ones.
  std::size_t moved_in_order = 0, kept_input = 0, failed = 0;
};

/// Runs meshlabserver in `work_dir` (created; its files are overwritten). Throws
/// std::runtime_error naming the log file when meshlabserver fails or writes no cloud.
MeshlabResult meshlab_mls(const std::vector<Vec3>& points, const MeshlabMlsParams& params,
                          const std::filesystem::path& work_dir);

}  // namespace pointfair::quality
