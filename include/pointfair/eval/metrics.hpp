#pragma once
// Quality of a point cloud against ground truth (`pointfair eval`, bench/quality):
//   distances  RMS and max distance to the true surface, divided by the bounding-box diagonal
//              of the truth;
//   CD, P2M    Chamfer and point-to-mesh distances in the convention of recent learned
//              denoisers (Luo & Hu 2021 and followers): both clouds translated by the centre
//              of the reference cloud's bounding box and divided by the reference cloud's
//              largest distance from that centre (the unit sphere), then
//                CD  = mean_x min_y |x - y|^2 + mean_y min_x |x - y|^2
//                P2M = mean_x dist(x, true surface)^2
//              reported x 1e4. Differs from pytorch3d's point_mesh_face_distance: our P2M is
//              one-directional (points to surface; no face-to-point term);
//   normals    angle between the PCA normal of the cloud (k nearest, default 16, unsigned) and
//              the true normal at the closest true point: overall, near sharp creases (closest
//              true point within `edge_band` x diagonal of a crease, or that of the clean
//              sample when the reference is the clean cloud in order) and elsewhere;
//   curvature  RMS over points of the error of (k1, k2) from the method's Weingarten map,
//              where the truth knows its curvature (analytic surfaces and polytope faces
//              outside the edge band);
//   features   precision and recall of the method's feature classes (edge or corner) against
//              "within the edge band of a true crease";
//   shrinkage  mean signed distance (negative: inside) / diagonal, change of the bounding-box
//              diagonal relative to the truth's, and the largest displacement from an input.
#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "pointfair/eval/truth.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair::eval {

struct EvalParams {
  /// Neighbours of the PCA normal that is compared with the true normal.
  int normal_k = 16;
  /// Half-width of the "near sharp creases" band, fraction of the bounding-box diagonal.
  double edge_band = 0.01;
  /// Method parameters of the curvature and feature classes that are scored.
  SmoothParams method;
  /// Compute curvature and feature scores (needs the method's attributes; off is faster).
  bool with_curvature = true;

  void validate() const;
};

/// Mean and RMS of an angle error (degrees) over a set of points.
struct AngleStats {
  std::size_t count = 0;
  double mean_degrees = 0.0;
  double rms_degrees = 0.0;
};

struct EvalReport {
  std::size_t points = 0;
  double diagonal = 0.0;  ///< of the truth's bounding box (length)
  double rms_distance = 0.0;   ///< / diagonal
  double max_distance = 0.0;   ///< / diagonal
  double rms_near_edges = 0.0;  ///< / diagonal, points in the edge band
  double rms_elsewhere = 0.0;   ///< / diagonal
  double chamfer_1e4 = 0.0;
  double p2m_1e4 = 0.0;
  AngleStats normal_all, normal_edges, normal_elsewhere;
  /// RMS error of (k1, k2), 1/length; nullopt where the truth has no curvature.
  std::optional<double> curvature_rms;
  std::size_t curvature_points = 0;
  /// Feature detection against the true creases; nullopt without creases.
  std::optional<double> feature_precision, feature_recall;
  std::size_t feature_predicted = 0, feature_true = 0;
  double mean_signed_distance = 0.0;  ///< / diagonal
  double bbox_diagonal_change = 0.0;  ///< (diag(cloud) - diag(truth)) / diag(truth)
  /// Largest and RMS |cloud_i - input_i| / diagonal; nullopt without an input.
  std::optional<double> max_displacement, rms_displacement;
};

/// The largest coordinate magnitude evaluate() measures: its squared distances and their sums
/// over billions of points stay finite (at 1e200 they overflowed and the mesh distance crashed).
inline constexpr double kEvalMaxCoordinate = 1e100;

struct EvalInput {
  std::span<const Vec3> cloud;
  /// Reference cloud of the Chamfer distance (the clean samples); empty: sample the truth
  /// with as many points as the cloud (seed 12345).
  std::span<const Vec3> reference;
  /// The cloud before processing, same order, for displacements; may be empty.
  std::span<const Vec3> input;
  /// When the reference has as many points as the cloud and this is set, it is the clean
  /// cloud in the same order, and a point is "near a crease" when its clean sample is (as
  /// in MATH.md), so that points a flow pulled away from an edge still count there.
  bool reference_in_order = true;
};

/// Scores `input.cloud` against `truth`. Throws ParamError for bad parameters, an empty cloud
/// or an input of a different size.
EvalReport evaluate(const GroundTruth& truth, const EvalInput& input, const EvalParams& params = {});

/// Unsigned angle in degrees between two lines with directions a and b (0..90).
double line_angle_degrees(const Vec3& a, const Vec3& b);

}  // namespace pointfair::eval
