#pragma once
// One explicit Euler step of the (an)isotropic mean curvature flow, Lange & Polthier (2005),
// Sections 2.3 and 4, double-buffered (Jacobi): every point reads only step-n positions and
// its fixed neighbour list, and writes its step-(n+1) position. Each point's result depends
// on nothing else, so the output is bit-identical for any thread count or tiling.
//   p_i <- p_i + tau A_i                       (default)
//   p_i <- p_i + tau <A_i, n_i> n_i            ("constrain interior": normal motion only)
#include <cstddef>
#include <span>
#include <vector>

#include "pointfair/curvature/curvature.hpp"
#include "pointfair/curvature/features.hpp"
#include "pointfair/flow/laplacian.hpp"
#include "pointfair/frames/frame.hpp"
#include "pointfair/frames/robust_frame.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"

namespace pointfair {

/// The tangent frame the flow reads: the PCA frame of the paper (eq. 1) or the robust frame
/// (robust_frame.hpp), which does not straddle sharp edges.
enum class NormalEstimator { Pca, Robust };

struct FlowParams {
  Flow flow = Flow::Anisotropic;
  Cutoff cutoff = Cutoff::Sharp;
  /// Cut-off threshold lambda (1/length). 0 chooses it automatically: lambda_auto_factor times
  /// the median over points of the median |kappa_ij| of each neighbourhood (when it is
  /// measured: see SmoothParams::lambda_every_step).
  double lambda = 0.0;
  /// 1 measured best on the demo octahedron (RMS 6.2e-3 vs 6.6e-3 at 0.75 and 6.7e-3 at 1.5).
  double lambda_auto_factor = 1.0;
  /// Step size tau in (0, 1] (dimensionless; the paper's lambda dt |N_i|). 1 moves a point
  /// to the mean of its (kept) neighbours.
  double tau = 0.5;
  /// Origin of the directional curvatures the cut-off reads (see CutoffOrigin): the point
  /// itself (the paper: Point) or its foot on the PCA plane of its neighbourhood (Plane). Only
  /// the anisotropic flow reads it. FlowParams{} is the paper's step; SmoothParams{} (the
  /// method's defaults) uses Plane.
  CutoffOrigin cutoff_origin = CutoffOrigin::Point;
  /// The paper's "constrain interior": move along the normal only.
  bool constrain_normal = false;
  /// With a feature mode: only feature points (edges, corners) use the cut-off; the others use
  /// the isotropic Laplacian. Off: every point uses the flow chosen above.
  bool feature_gated = false;
  FeatureParams features;
  WeingartenParams weingarten;
  NormalEstimator normal_estimator = NormalEstimator::Pca;
  RobustFrameParams robust;

  void validate() const;
};

/// Everything the method knows about one point at one step.
struct PointState {
  Frame frame;
  Curvature curvature;
  /// A_i, the (anisotropic) mean curvature vector of the Laplacian.
  Vec3 laplacian = Vec3::Zero();
  /// p_i(n+1) - p_i(n).
  Vec3 displacement = Vec3::Zero();
  FeatureClass feature = FeatureClass::Smooth;
  /// False when the point has too few neighbours or they do not span a plane; it stays put.
  bool valid = false;
};

/// The frame evaluate_point gives p (the robust plane or PCA, as `params` choose): the same
/// bits. Not valid with no neighbours.
Frame point_frame(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points,
                  const FlowParams& params, double lambda);

/// State of point p with neighbours `neighbors` (indices into `points`) under `params`, with
/// the resolved threshold `lambda`. Curvature and feature class are computed when
/// `with_curvature` or when the flow needs them (feature gating).
PointState evaluate_point(const Vec3& p, std::span<const Index> neighbors,
                          std::span<const Vec3> points, const FlowParams& params, double lambda,
                          bool with_curvature);

struct StepStats {
  /// Points that could not move because their neighbourhood is degenerate.
  std::size_t degenerate = 0;
};

/// One Euler step. Row r of `neighborhoods` belongs to point rows[r] of `current` (rows empty:
/// row r is point r); next[r] receives its new position. `current` and `next` must not alias.
StepStats euler_step(std::span<const Vec3> current, NeighborhoodsView neighborhoods,
                     std::span<const Index> rows, const FlowParams& params, double lambda,
                     std::span<Vec3> next);

/// The instructions the step's hot loop runs on. Both give the same bits: the sums run over
/// four lanes in the same order in either, and neither fuses a multiply into an add.
enum class StepKernel {
  /// The baseline of the build's target (SSE2 on x86-64): runs on any machine.
  Plain,
  /// 256-bit AVX2 vectors (x86-64 with GCC or Clang), chosen at run time.
  Avx2,
};

/// Whether this build and this CPU can run `kernel` (Plain always can).
bool step_kernel_available(StepKernel kernel);

/// The kernel euler_step uses: Avx2 where available, unless the environment variable
/// POINTFAIR_NO_AVX2 is set to anything but empty or "0". Decided once per process, from
/// nothing but the CPU and that variable, so every step, thread and tile uses the same one.
StepKernel default_step_kernel();

/// euler_step with the hot loop on `kernel` (tests and benchmarks compare them); a kernel
/// that is not available is a parameter error.
StepStats euler_step(std::span<const Vec3> current, NeighborhoodsView neighborhoods,
                     std::span<const Index> rows, const FlowParams& params, double lambda,
                     std::span<Vec3> next, StepKernel kernel);

/// The automatic lambda (see FlowParams::lambda) of `points` with `neighborhoods`, measured on
/// the points with original index 0, s, 2s, ... (s = max(1, n / 8192)). `row_of[i]` is where
/// original point i is stored (its row and position); empty means i itself.
double auto_lambda(std::span<const Vec3> points, const Neighborhoods& neighborhoods, double factor,
                   std::span<const Index> row_of = {});

/// The automatic lambda's per-point term: the median |kappa_ij| of point p with its
/// neighbours, or -1 when its frame is degenerate.
double median_abs_curvature(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points);
/// The automatic lambda from per-point medians (entries < 0 are skipped): factor times their
/// median; 1 for no usable entry; the largest double for a flat cloud (median 0).
double lambda_from_medians(std::vector<double> medians, double factor);

/// The threshold params ask for: params.lambda, or auto_lambda.
double resolve_lambda(std::span<const Vec3> points, const Neighborhoods& neighborhoods,
                      const FlowParams& params);

}  // namespace pointfair
