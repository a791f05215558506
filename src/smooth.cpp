#include "pointfair/smooth.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <tuple>
#include <utility>

#include <Eigen/Geometry>
#include <string>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/flow/coarse_moves.hpp"
#include "pointfair/flow/shrink_compensation.hpp"
#include "pointfair/neighbors/neighborhood_size.hpp"
#include "pointfair/neighbors/coarse_sample.hpp"
#include "pointfair/neighbors/spatial_order.hpp"

namespace pointfair {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

SmoothParams paper_smooth_params(SmoothParams base) {
  base.flow.cutoff_origin = CutoffOrigin::Point;
  base.flow.normal_estimator = NormalEstimator::Pca;
  base.flow.tau = 0.5;
  base.steps = 100;
  base.stop_lambda_ratio = 0.0;
  base.stop_plateau = 0.0;
  base.shrink_compensation = 0.0;
  base.momentum = 0.0;
  if (base.neighbors.k == 0) base.neighbors.k = kAutoKMin;
  base.finish.reset();
  base.coarse.reset();
  base.placement = Placement::Free;
  base.flow.features.scale = FeatureScale::Lambda;
  return base;
}

QuadricProjectionParams finish_after(const SmoothParams& params, bool coarse_level_ran) {
  QuadricProjectionParams q = *params.finish;
  if (coarse_level_ran && params.coarse && params.coarse->finish_passes > 0) q.passes = params.coarse->finish_passes;
  return q;
}

SmoothParams resolve_k(SmoothParams params, std::span<const Vec3> input) {
  if (params.neighbors.k == 0) params.neighbors.k = automatic_k(input);
  return params;
}

std::string_view to_string(StopReason reason) {
  switch (reason) {
    case StopReason::LambdaRatio: return "lambda_ratio";
    case StopReason::Plateau: return "plateau";
    case StopReason::StepLimit: return "step_limit";
  }
  return "?";
}

std::string_view to_string(SmoothStage stage) {
  switch (stage) {
    case SmoothStage::Neighbors: return "neighbors";
    case SmoothStage::Steps: return "steps";
    case SmoothStage::Finish: return "finish";
    case SmoothStage::CoarseSteps: return "coarse_steps";
  }
  return "?";
}

bool should_stop(const SmoothParams& params, std::span<const double> lambdas) {
  return stop_reason(params, lambdas).has_value();
}

std::optional<StopReason> stop_reason(const SmoothParams& params, std::span<const double> lambdas) {
  if (lambdas.size() < 2) return std::nullopt;
  const std::size_t n = lambdas.size() - 1;
  if (params.stop_lambda_ratio > 0.0 && lambdas[n] <= params.stop_lambda_ratio * lambdas[0])
    return StopReason::LambdaRatio;
  // A plateau counts once lambda has fallen to 0.7 of the input's: under heavy noise and
  // too small a k (fandisk at 1%, k 16) it also stalls early on, with most of the noise still
  // there. A lower gate (0.3 before the automatic k) kept that k-16 run going, but never let
  // a lightly noisy curved surface stop, whose lambda falls only to its own curvature: a
  // 20K-point torus at 0.1% noise ran all 150 steps and ended farther from the truth than its
  // input (RMS 1.009e-3 against 0.999e-3; 0.361e-3 after 11 steps with this gate).
  if (params.stop_plateau > 0.0 && n >= 8 && lambdas[n] <= 0.7 * lambdas[0] &&
      lambdas[n] > (1.0 - params.stop_plateau) * lambdas[n - 4])
    return StopReason::Plateau;
  return std::nullopt;
}

double momentum_of_step(const SmoothParams& params, int step, bool rebuilt, bool lambda_rose,
                        std::span<const double> lambdas) {
  if (step == 0 || rebuilt || lambda_rose || !has_momentum(params)) return 0.0;
  if (params.momentum_gate > 0.0 && (lambdas.size() < 2 || lambdas[1] < params.momentum_gate * lambdas[0])) return 0.0;
  return params.momentum;
}

bool has_momentum(const SmoothParams& params) {
  const bool gauged = params.flow.flow == Flow::Anisotropic && params.flow.lambda == 0.0 && params.lambda_every_step;
  return params.momentum > 0.0 && (params.momentum_gate == 0.0 || gauged);
}

bool measures_lambda_before(const SmoothParams& params, int step) {
  return params.flow.flow == Flow::Anisotropic || step == params.steps - 1;
}

void SmoothParams::validate() const {
  NeighborParams n = neighbors;
  if (n.k == 0) n.k = kAutoKMin;  // automatic
  n.validate();
  flow.validate();
  require(steps >= 0, "steps must be >= 0, got " + std::to_string(steps));
  require(rebuild_interval >= 0,
          "rebuild interval must be >= 0 (0 = never), got " + std::to_string(rebuild_interval));
  require(stop_lambda_ratio >= 0.0 && stop_lambda_ratio < 1.0,
          "stop lambda ratio must be in [0, 1) (0 = off), got " + std::to_string(stop_lambda_ratio));
  require(stop_plateau >= 0.0 && stop_plateau < 1.0,
          "stop plateau must be in [0, 1) (0 = off), got " + std::to_string(stop_plateau));
  require(momentum >= 0.0 && momentum < 1.0, "momentum must be in [0, 1) (0 = off), got " + std::to_string(momentum));
  require(momentum_gate >= 0.0 && momentum_gate <= 1.0,
          "momentum gate must be in [0, 1] (0 = always), got " + std::to_string(momentum_gate));
  require(shrink_compensation >= 0.0 && shrink_compensation <= 1.0,
          "shrink compensation must be in [0, 1] (0 = off), got " + std::to_string(shrink_compensation));
  if (finish) finish->validate();
  if (coarse) coarse->validate();
}

void CoarseLevelParams::validate() const {
  require(ratio >= 2, "coarse ratio must be >= 2, got " + std::to_string(ratio));
  require(fine_steps >= 0, "coarse fine steps must be >= 0, got " + std::to_string(fine_steps));
  require(interpolation_k >= 1 && interpolation_k <= 64,
          "coarse interpolation k must be in 1..64, got " + std::to_string(interpolation_k));
  require(levels >= 1 && levels <= 8, "coarse levels must be in 1..8, got " + std::to_string(levels));
  require(cell_spacings > 0.0 && std::isfinite(cell_spacings),
          "coarse cell spacings must be positive, got " + std::to_string(cell_spacings));
  require(finish_passes >= 0, "coarse finish passes must be >= 0, got " + std::to_string(finish_passes));
  require(min_noise_ratio >= 0.0 && std::isfinite(min_noise_ratio),
          "coarse minimum noise ratio must be >= 0, got " + std::to_string(min_noise_ratio));
}

namespace {

// The flow of smooth(): neighbourhoods and steps, `positions` in place.
SmoothReport run_flow(std::vector<Vec3>& positions, const SmoothParams& params, const SmoothOptions& options) {
  auto t0 = std::chrono::steady_clock::now();
  require(options.neighbor_reference.empty() ||
              options.neighbor_reference.size() == positions.size(),
          "the neighbour reference cloud must have as many points as the input (" +
              std::to_string(options.neighbor_reference.size()) + " vs " +
              std::to_string(positions.size()) + ")");
  SmoothReport report;
  report.k = params.neighbors.k;
  const std::span<const Vec3> first_source =
      options.neighbor_reference.empty() ? std::span<const Vec3>(positions) : options.neighbor_reference;
  // The steps run on the cloud stored in Morton order (neighbours near in memory). The
  // neighbourhoods are still built in the caller's order, so that their canonical tie rule
  // (ties by the smaller index) refers to the caller's indices; relabelling changes no bit of
  // the result (see spatial_order.hpp). They are built first and then relabelled and moved to
  // the Morton rows in place: the order and its inverse do not exist yet while the build holds
  // its grid, which keeps the peak memory of the whole run at the build's own.
  Neighborhoods neighborhoods = build_neighborhoods(first_source, params.neighbors);
  const std::vector<Index> order = spatial_order(positions);
  const std::vector<Index> row_of = inverse_permutation(order);
  permute_neighborhoods_in_place(neighborhoods, order, row_of);
  report.eps = neighborhoods.eps;
  // `positions` itself holds the current step (reordered in place: no copy), `next` the
  // other buffer. Whatever happens, the caller gets back the last completed step in its order.
  permute_in_place(positions, order);
  struct RestoreOrder {
    std::vector<Vec3>& positions;
    std::span<const Index> row_of;
    ~RestoreOrder() {
      try {
        permute_in_place(positions, row_of);
      } catch (...) {  // out of memory for the scratch bits while unwinding: leave as is
      }
    }
  } restore{positions, row_of};

  auto measure_lambda = [&] {
    return params.flow.lambda > 0.0
               ? params.flow.lambda
               : auto_lambda(positions, neighborhoods, params.flow.lambda_auto_factor, row_of);
  };
  report.lambda = measure_lambda();
  report.seconds_neighbors += seconds_since(t0);

  // `next` holds the step before the current one (for the momentum) until a step writes it.
  std::vector<Vec3> next(positions.size());
  // The flow's own update, when it is compensated (shrink_compensation.hpp) or has momentum.
  std::vector<Vec3> updated(params.shrink_compensation > 0.0 || has_momentum(params) ? positions.size() : 0);
  // lambdas[s]: the automatic lambda measured before step s + 1 (SmoothParams::stop_plateau).
  std::vector<double> lambdas{report.lambda};
  for (int step = 0; step < params.steps; ++step) {
    bool rebuilt = false, lambda_rose = false;
    if (params.rebuild_interval > 0 && step > 0 && step % params.rebuild_interval == 0) {
      rebuilt = true;
      t0 = std::chrono::steady_clock::now();
      neighborhoods = build_reordered_neighborhoods(scatter(positions, order), params.neighbors,
                                                    order, row_of);
      report.eps = neighborhoods.eps;
      report.lambda = measure_lambda();
      ++report.rebuilds;
      report.seconds_neighbors += seconds_since(t0);
    }
    t0 = std::chrono::steady_clock::now();
    if (params.lambda_every_step && step > 0 && measures_lambda_before(params, step)) {
      report.lambda = measure_lambda();
      lambda_rose = report.lambda > lambdas.back();
      lambdas.push_back(report.lambda);
      // The automatic lambda gauges the noise: stop once it has fallen far enough.
      const std::optional<StopReason> reason =
          params.flow.flow == Flow::Anisotropic && params.flow.lambda == 0.0 ? stop_reason(params, lambdas)
                                                                             : std::nullopt;
      if (reason) {
        report.stopped_early = true;
        report.stop_reason = *reason;
        report.seconds_steps += seconds_since(t0);
        break;
      }
    }
    const StepMomentum momentum{momentum_of_step(params, step, rebuilt, lambda_rose, lambdas), next, {}};
    // A restart: the step would have had momentum but for the rise.
    if (lambda_rose && momentum_of_step(params, step, rebuilt, false, lambdas) > 0.0) ++report.momentum_restarts;
    StepStats stats;
    if (updated.empty()) {
      stats = euler_step(positions, neighborhoods, {}, params.flow, report.lambda, next);
    } else if (params.shrink_compensation == 0.0) {
      stats = euler_step(positions, neighborhoods, {}, params.flow, report.lambda, updated);
      add_momentum(positions, updated, {}, momentum, next);
    } else {
      stats = euler_step(positions, neighborhoods, {}, params.flow, report.lambda, updated);
      to_updates(positions, updated);
      compensate_updates(positions, updated, neighborhoods, {}, params.shrink_compensation, momentum, next);
    }
    positions.swap(next);
    report.degenerate = stats.degenerate;
    report.seconds_steps += seconds_since(t0);
    ++report.steps;
    if (options.progress)
      options.progress(SmoothStage::Steps, static_cast<std::size_t>(step + 1), static_cast<std::size_t>(params.steps));
  }
  next = std::vector<Vec3>{};
  updated = std::vector<Vec3>{};
  // Back to the caller's rows only when the caller reads them (a serial pass over every list:
  // 0.2 s of a 1M-point run at k 48).
  if (options.keep_neighborhoods) {
    permute_neighborhoods_in_place(neighborhoods, row_of, order);
    report.neighborhoods = std::move(neighborhoods);
  }
  return report;
}

}  // namespace

namespace {

// The flow with the coarse levels of SmoothParams::coarse (none without it): `positions` in
// place; the coarse levels' points and steps, finest first, appended to `levels`.
SmoothReport flow_with_levels(std::vector<Vec3>& positions, SmoothParams params, const SmoothOptions& options,
                              std::vector<CoarseLevelReport>& levels);

// One coarse level under `positions` (whose noise is `noise`), if their noise is heavy enough
// (CoarseLevelParams::min_noise_ratio) and the coarse sample large enough: the sample smoothed
// (with coarse levels of its own, recursively) and every point moved by the displacement
// around it. False when there was none.
bool run_coarse_level(std::vector<Vec3>& positions, const SmoothParams& params, const NoiseEstimate& noise,
                      const SmoothOptions& options, std::vector<CoarseLevelReport>& levels) {
  const CoarseLevelParams& c = *params.coarse;
  // The noise estimate of a coarse sample does not fall as its spacing grows (the surface's
  // own curvature reads as noise at that scale): only the input's is tested, and the depth is
  // CoarseLevelParams::levels.
  if (levels.empty() && !(noise.ratio >= c.min_noise_ratio)) return false;
  // Every ratio-th point in Morton order within cells of cell_spacings sample spacings: a
  // sample as even as the cloud, in the input's order.
  const CoarseCells cells = coarse_cells(morton_grid(positions), c.cell_spacings * noise.spacing);
  const std::vector<Index> sample = coarse_sample(positions, cells, c.ratio);
  std::vector<Vec3> coarse_input(sample.size());
  for (std::size_t j = 0; j < sample.size(); ++j) coarse_input[j] = positions[sample[j]];
  // Too few for a surface of their own (the automatic k needs a few dozen): no coarse level.
  if (coarse_input.size() < 64) return false;
  SmoothParams coarse_params = params;
  coarse_params.finish.reset();
  coarse_params.placement = Placement::Free;
  coarse_params.neighbors.k = 0;  // measured on the coarse sample, whose spacing is larger
  const std::size_t at = levels.size();
  levels.push_back({coarse_input.size(), 0});
  std::vector<Vec3> coarse = coarse_input;
  // Its steps reported as the coarse level's (a coarser level's too).
  SmoothOptions coarse_options;
  if (options.progress)
    coarse_options.progress = [&options](SmoothStage stage, std::size_t done, std::size_t total) {
      if (stage == SmoothStage::Steps || stage == SmoothStage::CoarseSteps)
        options.progress(SmoothStage::CoarseSteps, done, total);
    };
  const SmoothReport coarse_report = flow_with_levels(coarse, coarse_params, coarse_options, levels);
  levels[at].steps = coarse_report.steps;
  // Only the coarse points' moves across the surface (along their normals) carry over: their
  // slide along it (the free flow's, towards denser parts) would move the points off the
  // places the placement keeps.
  const PointAttributes frames = compute_normals(coarse, coarse_report.neighborhoods, coarse_params.flow,
                                                 coarse_report.lambda);
  parallel_for(coarse.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j) {
      const Vec3& n = frames.normal[j];
      if (n.allFinite() && n.squaredNorm() > 0.5) coarse[j] = coarse_input[j] + (coarse[j] - coarse_input[j]).dot(n) * n;
    }
  }, 4096);
  // Each point moves by the coarse displacement around it: Gaussian weights over its
  // interpolation_k nearest coarse input points, the farthest at weight exp(-2).
  add_coarse_moves(positions, coarse_input, coarse, c.interpolation_k, cells.grid);
  return true;
}

SmoothReport flow_with_levels(std::vector<Vec3>& positions, SmoothParams params, const SmoothOptions& options,
                              std::vector<CoarseLevelReport>& levels) {
  const int requested_k = params.neighbors.k;
  // One noise estimate for the automatic k and the coarse level.
  const bool coarsen = params.coarse && static_cast<int>(levels.size()) < params.coarse->levels;
  NoiseEstimate noise;
  if (coarsen || params.neighbors.k == 0) noise = estimate_noise(positions);
  if (params.neighbors.k == 0) params.neighbors.k = k_for_noise_ratio(noise.ratio);
  if (coarsen && run_coarse_level(positions, params, noise, options, levels)) {
    // Every point then takes fine_steps steps, on neighbourhoods of the positions the coarse
    // level left (the automatic k measured on them when it was automatic).
    params.steps = params.coarse->fine_steps;
    params.stop_lambda_ratio = 0.0;
    params.stop_plateau = 0.0;
    params.neighbors.k = requested_k;
    params = resolve_k(params, positions);
  }
  return run_flow(positions, params, options);
}

}  // namespace

SmoothReport smooth(std::vector<Vec3>& positions, const SmoothParams& requested, const SmoothOptions& options) {
  requested.validate();
  require_finite(positions, "smooth");
  require(options.input_positions.empty() || options.input_positions.size() == positions.size(),
          "smooth: input_positions must hold one position per point (" + std::to_string(options.input_positions.size()) +
              " vs " + std::to_string(positions.size()) + ")");
  const bool place = requested.finish && requested.placement == Placement::AlongNormal;
  // The input positions the placement moves along the normals: the caller's, or a copy (24
  // bytes a point).
  std::vector<Vec3> input_copy;
  std::span<const Vec3> input;
  if (place) {
    if (options.input_positions.empty()) input_copy = positions;
    input = options.input_positions.empty() ? std::span<const Vec3>(input_copy) : options.input_positions;
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<CoarseLevelReport> levels;
  // Neighbourhoods from a reference cloud are for the points as they are: no coarse level.
  SmoothParams params = requested;
  if (!options.neighbor_reference.empty()) params.coarse.reset();
  SmoothReport report = flow_with_levels(positions, params, options, levels);
  report.coarse_levels = std::move(levels);
  if (!report.coarse_levels.empty())
    report.seconds_coarse = seconds_since(t0) - report.seconds_neighbors - report.seconds_steps;
  if (!requested.finish) return report;
  const auto t1 = std::chrono::steady_clock::now();
  FinishProgress finish_progress;
  if (options.progress)
    finish_progress = [&](std::size_t done, std::size_t total) { options.progress(SmoothStage::Finish, done, total); };
  const QuadricProjectionParams finish = finish_after(requested, !report.coarse_levels.empty());
  finish_with_quadrics(positions, finish, input, finish_progress);
  report.finish_passes = finish.passes;
  report.placed_along_normal = place;
  report.seconds_finish = seconds_since(t1);
  return report;
}

namespace {

// The centre of the cloud's bounding box, which the attributes' normals point away from.
Vec3 box_centre(std::span<const Vec3> positions) {
  Eigen::AlignedBox3d box;
  for (const auto& p : positions) box.extend(p);
  return !positions.empty() ? Vec3(box.center()) : Vec3(Vec3::Zero());
}

// The sign that turns `normal` (at p) away from `centre`.
double away_sign(const Vec3& normal, const Vec3& p, const Vec3& centre) {
  return normal.dot(p - centre) < 0.0 ? -1.0 : 1.0;
}

}  // namespace

PointAttributes compute_attributes(std::span<const Vec3> positions,
                                   const Neighborhoods& neighborhoods, const FlowParams& params,
                                   double lambda) {
  require(neighborhoods.size() == positions.size(), "compute_attributes: one neighbourhood row per point");
  return compute_attributes(positions, neighborhoods, box_centre(positions), params, lambda);
}

PointAttributes compute_normals(std::span<const Vec3> positions, const Neighborhoods& neighborhoods,
                                const FlowParams& params, double lambda) {
  const std::size_t n = neighborhoods.size();
  require(n == positions.size(), "compute_normals: one neighbourhood row per point");
  const Vec3 centre = box_centre(positions);
  PointAttributes a;
  a.normal.resize(n);
  std::atomic<std::size_t> degenerate{0};
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    std::size_t bad = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const Frame frame = point_frame(positions[i], neighborhoods.of(i), positions, params, lambda);
      if (!frame.valid) ++bad;
      a.normal[i] = away_sign(frame.normal, positions[i], centre) * frame.normal;
    }
    degenerate.fetch_add(bad, std::memory_order_relaxed);
  }, 1024);
  a.degenerate = degenerate.load();
  return a;
}

PointAttributes compute_attributes(std::span<const Vec3> positions, NeighborhoodsView neighborhoods,
                                   const Vec3& centre, const FlowParams& params, double lambda) {
  const std::size_t n = neighborhoods.size();
  require(n <= positions.size(), "compute_attributes: more neighbourhood rows than points");
  PointAttributes a;
  a.normal.resize(n);
  a.d1.resize(n);
  a.d2.resize(n);
  a.k1.resize(n);
  a.k2.resize(n);
  a.mean_curvature.resize(n);
  a.laplacian_norm.resize(n);
  a.feature.resize(n);
  std::atomic<std::size_t> degenerate{0};
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    std::size_t bad = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const PointState s = evaluate_point(positions[i], neighborhoods.of(i), positions, params, lambda, true);
      if (!s.valid) ++bad;
      const double sign = away_sign(s.frame.normal, positions[i], centre);
      a.normal[i] = sign * s.frame.normal;
      // The estimator's curvatures are positive where the surface bends toward its normal
      // (eq. 2); reported ones are positive where it bends away from the written normal, so
      // that a sphere with outward normals has k1 = k2 = +1/R. Negating a curvature pair
      // swaps the order of k1 >= k2 and of their directions.
      a.k1[i] = sign > 0 ? -s.curvature.k2 : s.curvature.k1;
      a.k2[i] = sign > 0 ? -s.curvature.k1 : s.curvature.k2;
      a.d1[i] = sign > 0 ? s.curvature.d2 : s.curvature.d1;
      a.d2[i] = sign > 0 ? s.curvature.d1 : s.curvature.d2;
      a.mean_curvature[i] = -sign * s.curvature.mean;
      a.laplacian_norm[i] = s.laplacian.norm();
      a.feature[i] = s.feature;
    }
    degenerate.fetch_add(bad, std::memory_order_relaxed);
  }, 1024);
  a.degenerate = degenerate.load();
  return a;
}

}  // namespace pointfair
