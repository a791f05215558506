#pragma once
// The whole in-core evolution: neighbourhoods, then `steps` double-buffered Euler steps,
// rebuilding the neighbourhoods every `rebuild_interval` steps if asked (Lange & Polthier
// 2005, Section 5: neighbourhoods are built once from the noisy input and kept fixed unless
// the user forces an update).
#include <cstddef>
#include <functional>
#include <span>
#include <vector>

#include "pointfair/euler_step.hpp"
#include "pointfair/neighborhoods.hpp"

namespace pointfair {

struct SmoothParams {
  NeighborParams neighbors;
  FlowParams flow;
  /// Number of Euler steps; 0 reproduces the input.
  int steps = 100;
  /// Rebuild the neighbourhoods from the current positions every this many steps; 0: never.
  int rebuild_interval = 0;
  /// With an automatic lambda: measure it again on the current positions before every step
  /// (true), or only on the input and after rebuilds (false). The noise dominates |kappa| at
  /// the start, so a threshold measured once stays too high as the noise goes away.
  bool lambda_every_step = true;

  void validate() const;
};

struct SmoothOptions {
  /// Build the (first) neighbourhoods from these positions instead of the input; same point
  /// order and count as the input (the paper's "noise-free neighbourhoods", Figures 3, 6d).
  std::span<const Vec3> neighbor_reference;
  /// Called after each step with (steps done, steps total).
  std::function<void(int, int)> progress;
};

struct SmoothReport {
  int steps = 0;
  /// Resolved radius bound and cut-off threshold (the last ones, if rebuilt).
  double eps = 0.0;
  double lambda = 0.0;
  int rebuilds = 0;
  /// Points that could not move in the last step (degenerate neighbourhoods).
  std::size_t degenerate = 0;
  double seconds_neighbors = 0.0;
  double seconds_steps = 0.0;
  /// The neighbourhoods in force at the end (for curvature output).
  Neighborhoods neighborhoods;
};

/// Runs the flow on `positions` in place. Throws ParamError on bad parameters. If anything
/// throws during the steps (including `progress`, which may throw to stop a run), `positions`
/// holds the last completed step.
SmoothReport smooth(std::vector<Vec3>& positions, const SmoothParams& params,
                    const SmoothOptions& options = {});

/// Per-point attributes as columns, for output.
struct PointAttributes {
  std::vector<Vec3> normal;
  std::vector<Vec3> d1;
  std::vector<Vec3> d2;
  std::vector<double> k1;
  std::vector<double> k2;
  std::vector<double> mean_curvature;
  /// |A_i|, the length of the (anisotropic) mean curvature vector.
  std::vector<double> laplacian_norm;
  std::vector<FeatureClass> feature;
  std::size_t degenerate = 0;
};

/// Frames, curvatures, Laplacians and feature classes of every point. Normals are oriented
/// away from the centre of the bounding box (a convention for output only; the method itself
/// never depends on the normal's sign). k1 >= k2 and H are signed so that the surface is
/// convex where they are positive: a sphere of radius R with outward normals has +1/R.
PointAttributes compute_attributes(std::span<const Vec3> positions,
                                   const Neighborhoods& neighborhoods, const FlowParams& params,
                                   double lambda);

}  // namespace pointfair
