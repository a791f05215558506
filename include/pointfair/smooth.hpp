#pragma once
// The whole in-core run, as `pointfair smooth` runs it: neighbourhoods, then `steps`
// double-buffered Euler steps, rebuilding the neighbourhoods every `rebuild_interval` steps if
// asked (Lange & Polthier 2005, Section 5: neighbourhoods are built once from the noisy input
// and kept fixed unless the user forces an update); then, beyond the paper, the quadric finish
// (quadric_projection.hpp) and the placement of every input point on the surface found.
#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "pointfair/finish/quadric_projection.hpp"
#include "pointfair/flow/euler_step.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"

namespace pointfair {

/// Where each output point goes (beyond the paper).
enum class Placement {
  /// Its input position moved along the surface normal onto the surface that the flow and the
  /// finish found (the finish's last pass evaluates each fit at the input point's tangent
  /// coordinates: placed_on_quadric): the noise across the surface is removed, the position
  /// along it is the input's, so that attributes stay on their spot and open borders stay
  /// where they were. Needs the finish; without it the flow's positions are kept.
  AlongNormal,
  /// Where the flow (and the finish) left it: the paper's free flow, which also moves points
  /// along the surface (towards denser regions, inward at open borders).
  Free,
};

/// A flow on a coarser sample before the flow on every point (beyond the paper). Under heavy
/// noise (noise sigma of a sample spacing or more) the explicit steps need many steps to carry
/// the smoothing across the noise's reach, about (sigma / spacing)^2; on every ratio-th point
/// (in Morton order) the spacing is sqrt(ratio) times larger, so a step there costs 1/ratio
/// and reaches as far as ratio steps on every point. Each point then moves by the coarse
/// points' displacement near it (a Gaussian-weighted mean over its interpolation_k nearest
/// coarse input points), and fine_steps steps on every point remove what the coarse sample
/// cannot see. With levels > 1 the coarse sample gets a coarse level of its own, and so on:
/// the coarsest level runs the flow with its automatic stop, each finer one fine_steps. The
/// finish and the placement follow as without it, the
/// placement measured from the input positions.
struct CoarseLevelParams {
  /// Every ratio-th point (>= 2) in Morton order within each cell (coarse_sample.hpp) is a
  /// coarse point. 2 measured better than 4, whose coarse neighbourhoods reach too far on
  /// curved surfaces (docs/coarse-level.md).
  int ratio = 2;
  /// The cells' edge in sample spacings (> 0; rounded down to a power of two of the Morton
  /// grid's quanta). 8 and 16 scored as well as the whole cloud's Morton order, 2 and 4 lost
  /// up to 8% of RMS (docs/coarse-level.md); a tile ranks the cells around it alone.
  double cell_spacings = 8.0;
  /// Steps on every point after the coarse flow (>= 0; the automatic stop does not apply).
  int fine_steps = 10;
  /// Coarse points each point's displacement is interpolated from (1..64).
  int interpolation_k = 8;
  /// Coarse levels under the input at most (1..8): the first coarse sample gets one of its
  /// own when levels >= 2, and so on.
  int levels = 1;
  /// The coarse levels run only when the input's noise is at least this many sample spacings
  /// (estimate_noise; >= 0). Below it the flow alone takes a few dozen steps at most, and the
  /// coarse level, closer to the surface or not, left worse normals near creases: the demo's
  /// octahedron (16K points, 1.76 spacings) RMS +7% and +1.0 degrees near creases, fandisk at
  /// 200K and 0.5% (1.62) RMS -5% but +1.6 degrees; from 2 spacings on it won: a 65K-point
  /// octahedron at 1.5% (2.16) RMS -19% and -2.5 degrees, fandisk at 1M and 0.5% (2.14) RMS
  /// -16% and -1.5 degrees, in a quarter of the steps (docs/coarse-level.md).
  double min_noise_ratio = 2.0;
  /// The quadric finish's passes after a coarse level ran (>= 0; 0: SmoothParams::finish's
  /// own). Its points come to the finish nearer the surface than the flow alone leaves them,
  /// and one pass did as well as two (the 1M-point fandisk at 0.5%: RMS 0.608 against 0.590,
  /// near creases 20.4 against 19.5 degrees, for 4.0 s of the finish's 7.5;
  /// docs/coarse-level.md); without a coarse level one pass lost 3-4% of RMS.
  int finish_passes = 1;
  void validate() const;
};

/// One coarse level of a run: its points and the steps its flow took.
struct CoarseLevelReport {
  std::size_t points = 0;
  int steps = 0;
};

struct SmoothParams {
  /// neighbors.k = 0 (the default here): chosen from the input's noise over its sample spacing
  /// (automatic_k, neighborhood_size.hpp), 16 under light noise up to 48 under noise of several
  /// spacings; any other k as given. Measured on fandisk (100K points) at 1% noise: RMS
  /// 2.09e-3 of the diagonal with the automatic k (48) against 3.09e-3 with 16, and the same
  /// 16 at 0.1% (README, Quality).
  NeighborParams neighbors{.k = 0};
  /// The flow. Unlike FlowParams{} (the paper's step), the defaults measure the cut-off's
  /// curvatures from each point's foot on its fitted plane (CutoffOrigin::Plane), fit that plane
  /// robustly (NormalEstimator::Robust), so that it does not straddle sharp edges, and take steps
  /// of tau 1 (with shrink_compensation below, larger steps stay stable and need fewer of them; 1
  /// against 0.8: a fifth fewer steps under heavy noise for the same result, the quality
  /// benchmark's verdicts as they were, docs/defaults.md). Measured on fandisk (100K points, seed
  /// 1; RMS distance in 1e-3 of the diagonal / normal error near creases, clean samples 13.6°)
  /// with all of this section's defaults (tau 0.8 then): 0.279 / 14.2° at 0.1% noise and 1.134 /
  /// 22.7° at 0.5%, against 0.353 / 15.9° and 1.446 / 26.7° without compensation (tau 0.5, stop
  /// at 0.2) and 0.74 / 16.9° and 2.03 / 33.3° for the paper's reading (paper_smooth_params).
  /// README, Quality. The robust plane reweights once (RobustFrameParams::iterations 1, not 3):
  /// the steps take half the time, and over the quality benchmark the normal error near creases
  /// rose by at most 0.6°, RMS by at most 1.2% (smooth models) and fell on the CAD models
  /// (docs/defaults.md). The robust plane is fitted only where the PCA plane is ambiguous
  /// (RobustFrameParams::gate 2: across creases and tight bends, not where noise alone spreads
  /// the neighbourhood); the steps take a third to a half of the time, with the quality
  /// benchmark's table in docs/defaults.md.
  FlowParams flow = [] {
    FlowParams f;
    f.cutoff_origin = CutoffOrigin::Plane;
    f.normal_estimator = NormalEstimator::Robust;
    f.robust.iterations = 1;
    f.robust.gate = 2.0;
    f.tau = 1.0;
    return f;
  }();
  /// Number of Euler steps; 0 reproduces the input.
  int steps = 150;
  /// Rebuild the neighbourhoods from the current positions every this many steps; 0: never.
  int rebuild_interval = 0;
  /// With an automatic lambda: measure it again on the current positions before every step
  /// (true), or only on the input and after rebuilds (false). The noise dominates |kappa| at
  /// the start, so a threshold measured once stays too high as the noise goes away. The
  /// isotropic flow measures only the one before its last step (measures_lambda_before).
  bool lambda_every_step = true;
  /// Automatic stop of the anisotropic flow (dimensionless, in [0, 1); 0 = off, always run
  /// `steps`): with an automatic lambda measured before every step, stop before the first step
  /// whose lambda is at most this fraction of the lambda of the input. The median |kappa_ij|
  /// is dominated by the noise, so its fall measures how much of the noise is gone, whatever
  /// its level, and the flow stops before it drifts; `steps` is then the most steps run.
  /// Ignored by the isotropic flow and with a fixed lambda or lambda measured once. 0.1 with
  /// the compensated flow (fandisk stops after 7 steps at 0.1% noise, 56 at 0.5%); without
  /// compensation 0.2 was the compromise (README, Quality). The out-of-core smoother stops at
  /// the same step.
  double stop_lambda_ratio = 0.1;
  /// Second automatic stop (dimensionless, in [0, 1); 0 = off), under the same conditions as
  /// stop_lambda_ratio: with lambda_s the automatic lambda measured before step s + 1
  /// (lambda_0 the input's), stop before step n + 1 (n >= 8 steps done) once
  /// lambda_n > (1 - stop_plateau) lambda_{n-4} and lambda_n <= 0.7 lambda_0. On a curved
  /// surface the median |kappa_ij| falls to the surface's own curvature, not to 0 (the
  /// bunny's clean samples score 0.12 of its noisy input at 0.1% noise): once it stops falling the noise is gone. 0.03 measured
  /// best with the compensated flow (README, Quality). The out-of-core smoother stops at the
  /// same step, also after --resume (it reads the earlier lambdas from its step log).
  double stop_plateau = 0.03;
  /// Shrinkage compensation beta in [0, 1] (0 = off, the paper): every step subtracts beta
  /// times the mean update of a point's neighbours from its own update
  /// (shrink_compensation.hpp), so that the flow removes noise without shrinking curved
  /// surfaces (B = 1 is the bi-Laplacian flow). 1 measured best, with the other defaults:
  /// sphere (20K points, 1% noise) RMS 1.90e-3 vs 2.54e-3 uncompensated, torus 2.04e-3 vs
  /// 3.07e-3, bunny (100K, 0.1%) 0.272e-3 vs 0.462e-3 (README, Quality). Out of core each
  /// tile then comes with the 2-ring closure of its lists (tiled_smooth.hpp).
  double shrink_compensation = 1.0;
  /// Momentum m in [0, 1) (dimensionless; 0 = off, the paper's plain steps; beyond the paper;
  /// 0.5 measured: the quality benchmark within 1% of no momentum, the 1M-point default run
  /// in half the steps; with tau 1, 0.55: 40 steps there instead of 45 for the same RMS, the
  /// quality benchmark's runs with momentum within 2.4% (0.6 lost 10% on the demo's
  /// octahedron, docs/momentum.md):
  /// each step also moves a point by m times its move in the step before,
  ///   p_i(n+1) = p_i(n) + c_i + m (p_i(n) - p_i(n-1))   (c_i the step, compensated or not),
  /// the heavy-ball scheme. Noise whose reach spans many sample spacings (heavy noise on a dense
  /// cloud) needs many plain steps, as each step smooths over one neighbourhood; with momentum
  /// those slow, smooth parts of the noise go about 1 / (1 - m) times faster per step. Where
  /// the automatic lambda (the noise gauge) rose since the step before, the step drops the
  /// momentum (a restart: the flow overshot), as it does on its first step and after a
  /// rebuild; and where the first (plain) step lowered the gauge below momentum_gate times the
  /// input's, the noise is fast to go and the run has none (momentum_of_step). Out of core
  /// too, to the same bits (the run file keeps every point's last move); measured in
  /// docs/momentum.md.
  double momentum = 0.55;
  /// Momentum only for slow runs (dimensionless, in [0, 1]; 0 = always): with lambda_1 the
  /// automatic lambda after the first step and lambda_0 the input's, a run whose lambda_1 <
  /// momentum_gate lambda_0 has no momentum. Light noise loses most of its gauge in the first
  /// step (a 20K-point sphere and torus at 0.1% keep 0.57 and 0.63 of it), where momentum only
  /// overshoots (the sphere's RMS +42% at 0.1% without the gate); heavy noise on a dense cloud
  /// keeps 0.94-1.0 of it. 0.9 measured: docs/momentum.md.
  double momentum_gate = 0.9;
  /// The quadric finish after the flow (quadric_projection.hpp, beyond the paper); empty: the
  /// flow's result as it is. Measured on the quality benchmark (docs/quality.md): lowers the
  /// RMS distance in 14 of 15 cases.
  std::optional<QuadricProjectionParams> finish = QuadricProjectionParams{};
  /// Where the output points go (Placement); AlongNormal needs the finish and is ignored
  /// without it.
  Placement placement = Placement::AlongNormal;
  /// A coarse level before the flow (CoarseLevelParams, beyond the paper); empty: none. On
  /// by default: it runs only under heavy noise (CoarseLevelParams::min_noise_ratio), where
  /// it is faster and closer to the surface (docs/coarse-level.md).
  std::optional<CoarseLevelParams> coarse = CoarseLevelParams{};

  void validate() const;
};

/// Why the flow stopped.
enum class StopReason {
  /// SmoothParams::stop_lambda_ratio: lambda fell to that fraction of the input's.
  LambdaRatio,
  /// SmoothParams::stop_plateau: lambda stopped falling.
  Plateau,
  /// SmoothParams::steps were run.
  StepLimit,
};

/// The momentum of step `step` (0-based; SmoothParams::momentum): none on the first step, on a
/// step that starts from rebuilt neighbourhoods, where the automatic lambda measured before it
/// rose above the one measured before the step before (`lambda_rose`: a restart), or in a run
/// the gate turned it off for (SmoothParams::momentum_gate; `lambdas` as stop_reason reads
/// them: the input's and those measured before each step since). The gate reads the noise
/// gauge, the automatic lambda of the anisotropic flow measured before every step: a run
/// without it (the isotropic flow, a fixed lambda, a lambda measured once) has momentum only
/// with the gate off (momentum_gate 0).
double momentum_of_step(const SmoothParams& params, int step, bool rebuilt, bool lambda_rose,
                        std::span<const double> lambdas);

/// Whether a step of a run with `params` may have momentum at all: momentum > 0, and the gate
/// off or a gauge for it (momentum_of_step).
bool has_momentum(const SmoothParams& params);

/// "lambda_ratio", "plateau", "step_limit".
std::string_view to_string(StopReason reason);

/// A stage of smooth(), for progress.
enum class SmoothStage { Neighbors, Steps, Finish, CoarseSteps };

/// "neighbors", "steps", "finish", "coarse_steps" (the steps of a coarse level's flow,
/// SmoothParams::coarse).
std::string_view to_string(SmoothStage stage);

/// The method as the paper states it, on top of `base` (its neighbourhoods, lambda and
/// feature settings are kept): the cut-off's curvatures from the point itself, PCA planes,
/// tau 0.5, 100 steps, no automatic stop, no shrinkage compensation, no automatic k (the
/// paper sets k by hand: an automatic k becomes 16, a given one is kept), no finish, the
/// free flow's positions and feature classes thresholded by lambda, no coarse level. The CLI's --paper.
SmoothParams paper_smooth_params(SmoothParams base = {});

/// The finish a run of `params` takes (params.finish must hold one): its passes
/// CoarseLevelParams::finish_passes when a coarse level ran.
QuadricProjectionParams finish_after(const SmoothParams& params, bool coarse_level_ran);

/// `params` with neighbors.k resolved: automatic_k(input) when it is 0.
SmoothParams resolve_k(SmoothParams params, std::span<const Vec3> input);

/// The automatic stop (stop_lambda_ratio, stop_plateau): true when the flow should stop
/// before step n + 1, given lambdas[s] = the automatic lambda measured before step s + 1 for
/// s = 0..n (lambdas[0] on the input). The caller checks that the stop applies at all
/// (anisotropic flow, automatic lambda measured every step).
bool should_stop(const SmoothParams& params, std::span<const double> lambdas);
/// The same test, with which of the two stops applies (the lambda ratio first); empty: none.
std::optional<StopReason> stop_reason(const SmoothParams& params, std::span<const double> lambdas);

/// With an automatic lambda measured every step (SmoothParams::lambda_every_step): whether it
/// is measured again before step `step` (> 0). Always for the anisotropic flow; the isotropic
/// flow reads no threshold and measures only the one before its last step, the threshold of
/// its attributes' feature classes. The out-of-core smoother follows the same rule.
bool measures_lambda_before(const SmoothParams& params, int step);

struct SmoothOptions {
  /// Build the (first) neighbourhoods from these positions instead of the input; same point
  /// order and count as the input (the paper's "noise-free neighbourhoods", Figures 3, 6d).
  /// The coarse level (SmoothParams::coarse) does not run then.
  std::span<const Vec3> neighbor_reference;
  /// Called with (stage, done, total): after each step (steps done, the most steps) and after
  /// each block of each finish pass (points done over all passes, points x passes). May throw
  /// to stop the run (smooth() then leaves `positions` as documented there).
  std::function<void(SmoothStage, std::size_t, std::size_t)> progress;
  /// Return the flow's last neighbourhoods in SmoothReport::neighborhoods (compute_attributes
  /// reads them). false: they are let go before the finish, whose peak memory is then 4 k
  /// bytes a point lower (192 at k 48).
  bool keep_neighborhoods = true;
  /// The input positions, when the caller keeps a copy of them anyway (same size and order as
  /// the positions smooth() is given): the placement along the normals reads them instead of
  /// a copy of its own (24 bytes a point). Empty: smooth() copies them.
  std::span<const Vec3> input_positions;
};

struct SmoothReport {
  int steps = 0;
  /// The coarse levels that ran (SmoothParams::coarse), finest first; `steps` are the steps
  /// on every point.
  std::vector<CoarseLevelReport> coarse_levels;
  /// The neighbourhood size used (the automatic choice or neighbors.k).
  int k = 0;
  /// Resolved radius bound and cut-off threshold (the last ones, if rebuilt).
  double eps = 0.0;
  double lambda = 0.0;
  int rebuilds = 0;
  /// Steps whose momentum was dropped because the noise gauge rose (SmoothParams::momentum).
  int momentum_restarts = 0;
  /// True when an automatic stop ended the flow before `steps` (stop_reason says which).
  bool stopped_early = false;
  StopReason stop_reason = StopReason::StepLimit;
  /// Finish passes run, and whether the input points were placed along the normals.
  int finish_passes = 0;
  bool placed_along_normal = false;
  /// Points that could not move in the last step (degenerate neighbourhoods).
  std::size_t degenerate = 0;
  double seconds_neighbors = 0.0;
  double seconds_steps = 0.0;
  double seconds_finish = 0.0;
  /// The coarse level, all of it (its neighbourhoods, steps and the interpolation).
  double seconds_coarse = 0.0;
  /// The neighbourhoods in force at the end (for curvature output).
  Neighborhoods neighborhoods;
};

/// Runs the flow, then the finish and the placement (SmoothParams::finish, placement), on
/// `positions` in place. Throws ParamError on bad parameters. If anything throws during the
/// steps (including `progress`, which may throw to stop a run), `positions` holds the last
/// completed step; during the finish, the last completed step or finish pass.
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

/// compute_attributes' normals alone, to the bit, and its count of degenerate points; the
/// other columns are left empty. For an output that refreshes its normal columns and writes
/// no other attribute: the curvatures, Laplacians and feature classes took two thirds of the
/// attributes' time.
PointAttributes compute_normals(std::span<const Vec3> positions, const Neighborhoods& neighborhoods,
                                const FlowParams& params, double lambda);

/// compute_attributes of points 0 .. neighborhoods.size() - 1 alone (every point of
/// `positions` may be their neighbour), normals oriented away from `centre`: what the whole
/// call gives those points when `centre` is the centre of the whole cloud's bounding box.
PointAttributes compute_attributes(std::span<const Vec3> positions, NeighborhoodsView neighborhoods,
                                   const Vec3& centre, const FlowParams& params, double lambda);

}  // namespace pointfair
