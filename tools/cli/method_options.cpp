#include "method_options.hpp"

#include "help_defaults.hpp"
#include "number_text.hpp"

#include <cmath>
#include <limits>
#include <optional>

namespace pointfair::cli {
namespace {

// The choice `text` of --`option`, by the names of its enum's table (smooth_names.hpp).
template <class Enum>
Enum parse_choice(std::string_view text, std::string_view option) {
  if (const std::optional<Enum> value = enum_from_name<Enum>(text)) return *value;
  std::string names;
  for (const EnumName<Enum>& e : enum_names(Enum{})) {
    names += names.empty() ? "" : ", ";
    names += e.name;
  }
  throw UsageError("--" + std::string(option) + " must be one of " + names + ", got '" +
                   std::string(text) + "'");
}

}  // namespace

std::string to_string(Flow flow) { return std::string(name_of(flow)); }
std::string to_string(Cutoff cutoff) { return std::string(name_of(cutoff)); }
std::string to_string(NormalEstimator normal) { return std::string(name_of(normal)); }
std::string to_string(FeatureMode mode) { return std::string(name_of(mode)); }
std::string to_string(AngularWeights weights) { return std::string(name_of(weights)); }
std::string to_string(ColourBy colour) { return std::string(name_of(colour)); }
std::string to_string(Placement placement) { return std::string(name_of(placement)); }

void add_method_options(ArgumentParser& p, SmoothParams& s) {
  const OptionGroup before = p.current_group();
  p.group(OptionGroup::Method);
  p.flag("paper",
         "The method as the paper states it: --cutoff-origin point --normal pca --tau 0.5 "
         "--steps 100 --stop-lambda-ratio 0 --stop-plateau 0 --shrink-compensation 0 "
         "--feature-threshold lambda --no-quadric-finish --move free. Options after it override it.",
         [&s] { s = paper_smooth_params(s); });
  p.value("move", "normal|free",
          "Where each point goes: 'normal' moves its input position along the surface normal "
          "onto the smoothed surface (the finish's fits evaluated at the input point), so that "
          "points do not slide along the surface and open borders stay put; 'free' keeps where "
          "the flow and the finish left it (the paper's flow, which also moves points along the "
          "surface). 'normal' needs the finish: with --no-quadric-finish the flow's positions "
          "are written. Default normal (--paper: free).",
          [&s](std::string_view v) {
            s.placement = parse_choice<Placement>(v, "move");
          });
  p.value("k", "N|auto",
          "Neighbours per point, the point itself not counted (1..1024). 'auto': chosen from the "
          "input's noise over its sample spacing, 16 under light noise up to 48 under noise of "
          "several spacings (--paper: 16). Default auto.",
          [&s](std::string_view v) {
            s.neighbors.k = v == "auto" ? 0 : parse_int(v, "--k");
            if (s.neighbors.k == 0 && v != "auto") throw UsageError("--k must be 1..1024 or 'auto'");
          });
  p.value("eps", "LENGTH|auto|inf",
          "Radius bound of the eps-k neighbourhood, in the cloud's length unit. 'auto': "
          "--eps-factor times the median distance to the k-th neighbour; 'inf': plain k-nearest. "
          "Default auto.",
          [&s](std::string_view v) {
            if (v == "auto") s.neighbors.eps = 0.0;
            else if (v == "inf") s.neighbors.eps = std::numeric_limits<double>::infinity();
            else {
              s.neighbors.eps = parse_double(v, "--eps");
              if (!(s.neighbors.eps > 0.0)) throw UsageError("--eps must be positive, 'auto' or 'inf'");
            }
          });
  p.group(OptionGroup::Advanced);
  p.value("eps-factor", "F", "Multiplier of the automatic eps (dimensionless). " + smooth_default("eps_factor") + ".",
          [&s](std::string_view v) { s.neighbors.eps_auto_factor = parse_double(v, "--eps-factor"); });
  p.group(OptionGroup::Method);
  p.value("steps", "N",
          "Explicit Euler steps (0 reproduces the input); the most steps run when "
          "an automatic stop ends the anisotropic flow earlier. " + smooth_default("steps") + ".",
          [&s](std::string_view v) { s.steps = parse_int(v, "--steps"); });
  p.value("tau", "T",
          "Step size tau in (0, 1], dimensionless: 1 moves a point to the mean of its kept "
          "neighbours. " + smooth_default("tau") + " (the paper: 0.5).",
          [&s](std::string_view v) { s.flow.tau = parse_double(v, "--tau"); });
  p.value("flow", "iso|aniso", "Isotropic (umbrella) or anisotropic Laplacian. " + smooth_default("flow") + ".",
          [&s](std::string_view v) {
            s.flow.flow = parse_choice<Flow>(v, "flow");
          });
  p.value("cutoff", "sharp|continuous",
          "Cut-off on |kappa_ij|: drop neighbours at or above lambda, or shade them out with "
          "lambda^2 / (lambda^2 + 10 (|kappa| - lambda)^2). " + smooth_default("cutoff") + ".",
          [&s](std::string_view v) {
            s.flow.cutoff = parse_choice<Cutoff>(v, "cutoff");
          });
  p.group(OptionGroup::Advanced);
  p.value("cutoff-origin", "point|plane",
          "Where the cut-off's directional curvatures kappa_ij are measured from: the point "
          "itself (the paper) or its foot on the PCA plane of its neighbourhood, so that a point's "
          "own noise does not decide which neighbours are kept. " + smooth_default("cutoff_origin") + ".",
          [&s](std::string_view v) {
            s.flow.cutoff_origin = parse_choice<CutoffOrigin>(v, "cutoff-origin");
          });
  p.group(OptionGroup::Method);
  p.value("lambda", "CURVATURE|auto",
          "Cut-off threshold lambda, a curvature (1/length). 'auto': --lambda-factor times the "
          "median over points of the median |kappa_ij| (see --lambda-schedule). Default auto.",
          [&s](std::string_view v) {
            if (v == "auto") s.flow.lambda = 0.0;
            else {
              s.flow.lambda = parse_double(v, "--lambda");
              if (!(s.flow.lambda > 0.0)) throw UsageError("--lambda must be positive or 'auto'");
            }
          });
  p.group(OptionGroup::Advanced);
  p.value("lambda-schedule", "once|every-step",
          "When lambda is automatic: measure it once on the input (and after rebuilds), or again "
          "before every step. Default every-step.",
          [&s](std::string_view v) {
            if (v == "once") s.lambda_every_step = false;
            else if (v == "every-step") s.lambda_every_step = true;
            else throw UsageError("--lambda-schedule must be one of once, every-step, got '" + std::string(v) + "'");
          });
  p.value("stop-lambda-ratio", "R",
          "Automatic stop of the anisotropic flow, R in [0, 1) (dimensionless): with --lambda auto "
          "and --lambda-schedule every-step, stop once lambda has fallen to R times its value on "
          "the input (the noise is then mostly gone); --steps is the most steps run. 0 = always "
          "run --steps (the paper). " + smooth_default("stop_lambda_ratio") + ".",
          [&s](std::string_view v) { s.stop_lambda_ratio = parse_double(v, "--stop-lambda-ratio"); });
  p.value("stop-plateau", "D",
          "Second automatic stop, D in [0, 1) (dimensionless), under the same conditions as "
          "--stop-lambda-ratio: stop once lambda has fallen by less than the fraction D over the "
          "last 4 steps (from 8 steps on): on a curved surface lambda falls to the surface's own "
          "curvature, not to 0. 0 = off (the paper). " + smooth_default("stop_plateau") + ".",
          [&s](std::string_view v) { s.stop_plateau = parse_double(v, "--stop-plateau"); });
  p.value("shrink-compensation", "B",
          "Shrinkage compensation, B in [0, 1] (dimensionless): subtract B times the mean update "
          "of a point's neighbours from its own update in every step (B = 1: the bi-Laplacian "
          "flow), so that curved surfaces do not shrink as the noise goes. 0 = the paper's flow. " +
              smooth_default("shrink_compensation") + ".",
          [&s](std::string_view v) { s.shrink_compensation = parse_double(v, "--shrink-compensation"); });
  p.value("momentum", "M",
          "Momentum, M in [0, 1) (dimensionless; beyond the paper): each step also moves a point by "
          "M times its move in the step before (heavy ball), dropped for a step where the noise "
          "gauge (the automatic lambda) rose; heavy noise on dense clouds goes in far fewer steps. "
          "0 = off (the paper's steps). " + smooth_default("momentum") + ".",
          [&s](std::string_view v) { s.momentum = parse_double(v, "--momentum"); });
  p.value("momentum-gate", "G",
          "Momentum only in runs whose first step left at least G times the input's noise gauge "
          "(G in [0, 1], dimensionless): light noise, which the first step mostly removes, gets "
          "none. 0 = always. " + smooth_default("momentum_gate") + ".",
          [&s](std::string_view v) { s.momentum_gate = parse_double(v, "--momentum-gate"); });
  p.value("lambda-factor", "F", "Multiplier of the automatic lambda (dimensionless). " + smooth_default("lambda_factor") + ".",
          [&s](std::string_view v) { s.flow.lambda_auto_factor = parse_double(v, "--lambda-factor"); });
  p.flag("constrain-normal",
         "The paper's 'constrain interior': move each point along its normal only. " +
             smooth_default("constrain_normal") + ".",
         [&s] { s.flow.constrain_normal = true; });
  p.value("normal", "pca|robust",
          "Tangent frame of the flow: the PCA plane of the whole neighbourhood (the paper) or a "
          "robust plane refitted from the nearest neighbours with Tukey weights, which does not "
          "straddle sharp edges. " + smooth_default("normal") + ".",
          [&s](std::string_view v) {
            s.flow.normal_estimator = parse_choice<NormalEstimator>(v, "normal");
          });
  p.value("robust-seed", "N",
          "Nearest neighbours of the robust frame's seed plane. " + smooth_default("robust_seed") + ".",
          [&s](std::string_view v) { s.flow.robust.seed_neighbors = parse_int(v, "--robust-seed"); });
  p.value("robust-iterations", "N",
          "Reweighting passes of the robust frame. " + smooth_default("robust_iterations") + ".",
          [&s](std::string_view v) { s.flow.robust.iterations = parse_int(v, "--robust-iterations"); });
  p.value("robust-bound", "C",
          "Tukey bound of the robust frame in robust-scale units (dimensionless). " +
              smooth_default("robust_bound") + ".",
          [&s](std::string_view v) { s.flow.robust.inlier_bound = parse_double(v, "--robust-bound"); });
  p.value("robust-gate", "G",
          "Where the robust frame is fitted (dimensionless; 0 = at every point): a point keeps its "
          "PCA plane unless that plane's smallest covariance eigenvalue exceeds G (lambda x "
          "trace)^2, as across a crease; under noise alone it stays below. " +
              smooth_default("robust_gate") + ".",
          [&s](std::string_view v) { s.flow.robust.gate = parse_double(v, "--robust-gate"); });
  p.value("rebuild-every", "M",
          "Rebuild the neighbourhoods from the current positions every M steps; 0 = never "
          "(the paper's default: built once from the input). " + smooth_default("rebuild") + ".",
          [&s](std::string_view v) { s.rebuild_interval = parse_int(v, "--rebuild-every"); });
  p.group(OptionGroup::Method);
  p.value("features", "none|quotient|maxcurv",
          "Feature detection: edge quotient |k_min|/|k_max| < Q with |k_max| >= threshold, or "
          "|k_max| >= threshold; both principal curvatures above it make a corner. " +
              smooth_default("features") + ".",
          [&s](std::string_view v) {
            s.flow.features.mode = parse_choice<FeatureMode>(v, "features");
          });
  p.group(OptionGroup::Advanced);
  p.value("edge-quotient", "Q", "Edge quotient threshold Q in [0, 1] (dimensionless). " + smooth_default("quotient") + ".",
          [&s](std::string_view v) { s.flow.features.quotient = parse_double(v, "--edge-quotient"); });
  p.group(OptionGroup::Method);
  p.value("feature-threshold", "auto|lambda|CURVATURE",
          "Curvature threshold of feature detection. 'auto': --feature-turn over each point's "
          "neighbourhood radius (its farthest neighbour), so that a point is a feature where the "
          "surface turns by more than that angle across its neighbourhood, whatever the rest of "
          "the cloud is (flat ground stays smooth). 'lambda': the flow's lambda, relative to the "
          "cloud's median curvature (the rule before 'auto'; on a mostly flat scan its residual "
          "noise then reads as edges). A number: that curvature (1/length) everywhere. "
          "Default auto (--paper: lambda).",
          [&s](std::string_view v) {
            s.flow.features.threshold = 0.0;
            if (v == "auto") s.flow.features.scale = FeatureScale::Spacing;
            else if (v == "lambda") s.flow.features.scale = FeatureScale::Lambda;
            else {
              s.flow.features.threshold = parse_double(v, "--feature-threshold");
              if (!(s.flow.features.threshold > 0.0))
                throw UsageError("--feature-threshold must be positive, 'auto' or 'lambda'");
            }
          });
  p.group(OptionGroup::Advanced);
  p.value("feature-turn", "RADIANS",
          "With --feature-threshold auto: the turn of the normal over one neighbourhood radius "
          "that makes a feature (radians; 0.25 is about 14 degrees). " + smooth_default("feature_turn") + ".",
          [&s](std::string_view v) { s.flow.features.turn = parse_double(v, "--feature-turn"); });
  p.flag("feature-gated",
         "Apply the cut-off only at detected feature points (edges, corners); other points "
         "flow isotropically. " + smooth_default("feature_gated") + ".",
         [&s] { s.flow.feature_gated = true; });
  p.value("weights", "paper|uniform",
          "Angular weights of the Weingarten map: the paper's |e|/delta density weights or "
          "uniform. " + smooth_default("weights") + ".",
          [&s](std::string_view v) {
            s.flow.weingarten.weights = parse_choice<AngularWeights>(v, "weights");
          });
  p.value("density-floor", "F",
          "Lower clamp of the directional density delta_ij, as a fraction of c1 + c2, in (0, 1]. " +
              smooth_default("density_floor") + ".",
          [&s](std::string_view v) { s.flow.weingarten.density_floor = parse_double(v, "--density-floor"); });
  // A --coarse-* value turns the coarse level on (with the defaults for the values not given).
  const auto coarse = [&s]() -> CoarseLevelParams& {
    if (!s.coarse) s.coarse.emplace();
    return *s.coarse;
  };
  const CoarseLevelParams c;
  p.group(OptionGroup::Method);
  p.flag("coarse-level",
         "Before the flow on every point, run it on every --coarse-ratio-th point (in Morton "
         "order within cells of --coarse-cell spacings), move each point by the coarse displacement near it, then take "
         "--coarse-fine-steps steps on every point, and --coarse-finish-passes passes of the finish; only where "
         "the input's noise is at least --coarse-min-noise sample spacings (beyond the paper; in core and out of core): under "
         "heavy noise closer to the surface in fewer steps (docs/coarse-level.md). Default on (--paper: off); a "
         "--coarse-* option turns it on.",
         [coarse] { coarse(); });
  p.flag("no-coarse-level", "Run the flow on every point from the start (--paper implies it).",
         [&s] { s.coarse.reset(); });
  p.group(OptionGroup::Advanced);
  p.value("coarse-ratio", "R",
          "Points per coarse point (>= 2). Implies --coarse-level. Default " + std::to_string(c.ratio) + ".",
          [coarse](std::string_view v) { coarse().ratio = parse_int(v, "--coarse-ratio"); });
  p.value("coarse-cell", "S",
          "Edge of the cells the coarse sample is drawn in, in sample spacings (> 0; rounded down "
          "to a power of two of the Morton grid): every --coarse-ratio-th point in Morton order "
          "within each cell. Implies --coarse-level. Default " + format_number(c.cell_spacings) + ".",
          [coarse](std::string_view v) { coarse().cell_spacings = parse_double(v, "--coarse-cell"); });
  p.value("coarse-levels", "L",
          "Coarse levels under the input (1..8; each coarse sample gets one of its own). Implies "
          "--coarse-level. Default " + std::to_string(c.levels) + ".",
          [coarse](std::string_view v) { coarse().levels = parse_int(v, "--coarse-levels"); });
  p.value("coarse-fine-steps", "N",
          "Steps on every point after the coarse level (the automatic stop does not apply). "
          "Implies --coarse-level. Default " + std::to_string(c.fine_steps) + ".",
          [coarse](std::string_view v) { coarse().fine_steps = parse_int(v, "--coarse-fine-steps"); });
  p.value("coarse-min-noise", "R",
          "The input's noise (in sample spacings, as 'pointfair info' reports it) from which the coarse "
          "level runs (>= 0). Implies --coarse-level. Default " + format_number(c.min_noise_ratio) + ".",
          [coarse](std::string_view v) { coarse().min_noise_ratio = parse_double(v, "--coarse-min-noise"); });
  p.value("coarse-finish-passes", "N",
          "Passes of the quadric finish after a coarse level ran (0: --quadric-passes). Implies "
          "--coarse-level. Default " + std::to_string(c.finish_passes) + ".",
          [coarse](std::string_view v) { coarse().finish_passes = parse_int(v, "--coarse-finish-passes"); });
  p.group(before);
}

void add_finish_options(ArgumentParser& p, SmoothParams& s) {
  const OptionGroup before = p.current_group();
  // A --quadric-* value turns the finish on (with the defaults for the values not given).
  const auto finish = [&s]() -> QuadricProjectionParams& {
    if (!s.finish) s.finish.emplace();
    return *s.finish;
  };
  p.group(OptionGroup::Method);
  p.flag("quadric-finish",
         "After the flow, move every point onto a cubic fitted to its --quadric-k nearest "
         "neighbours whose normals lie within --quadric-angle of its own, within "
         "--quadric-curvature-reach of its curvature (Tukey-reweighted, --quadric-passes times): "
         "removes the noise the flow leaves on smooth surfaces, keeps creases. Beyond the paper; "
         "out of core too. Default on (--paper: off); a --quadric-* option turns it on.",
         [finish] { finish(); });
  p.flag("no-quadric-finish", "Leave the flow's result as it is (--paper implies it).",
         [&s] { s.finish.reset(); });
  p.group(OptionGroup::Advanced);
  p.value("quadric-k", "N", "Neighbours of each quadric fit (5..1024). " + finish_default("quadric_k") + ".",
          [finish](std::string_view v) { finish().k = parse_int(v, "--quadric-k"); });
  p.value("quadric-angle", "DEGREES",
          "Largest angle between a point's normal and a neighbour's that keeps the neighbour in "
          "the point's quadric fit, in (0, 90]. " + finish_default("quadric_angle") + ".",
          [finish](std::string_view v) { finish().normal_angle = parse_double(v, "--quadric-angle"); });
  p.value("quadric-degree", "2|3",
          "Degree of each fitted height field: 2 (a quadric) or 3 (a cubic, which follows a "
          "neighbourhood lying to one side of the point). " + finish_default("quadric_degree") + ".",
          [finish](std::string_view v) { finish().degree = parse_int(v, "--quadric-degree"); });
  p.value("quadric-passes", "N",
          "Passes of the finish, each with neighbourhoods, normals and fits from the last one's "
          "result (1..10). " + finish_default("quadric_passes") + ".",
          [finish](std::string_view v) { finish().passes = parse_int(v, "--quadric-passes"); });
  p.value("quadric-iterations", "N",
          "Tukey reweighting passes of each fit after its first, unweighted one (0..20). " +
              finish_default("quadric_iterations") + ".",
          [finish](std::string_view v) { finish().iterations = parse_int(v, "--quadric-iterations"); });
  p.value("quadric-early-degree", "2|3",
          "Degree of the height fields of the passes before the last, which only bring the "
          "points near the surface for the last pass's fits. " + finish_default("quadric_early_degree") + ".",
          [finish](std::string_view v) { finish().early_degree = parse_int(v, "--quadric-early-degree"); });
  p.value("quadric-early-iterations", "N",
          "Tukey reweighting passes of each fit of the passes before the last (0..20). " +
              finish_default("quadric_early_iterations") + ".",
          [finish](std::string_view v) { finish().early_iterations = parse_int(v, "--quadric-early-iterations"); });
  p.value("quadric-curvature-reach", "C",
          "Fit each quadric only to the neighbours within C / kappa of the point, kappa the "
          "largest principal curvature of a pilot quadric over its --quadric-min-k nearest: "
          "narrow fits on fine detail, wide ones where the surface is flat. 0: all --quadric-k. " +
              finish_default("quadric_curvature_reach") + ".",
          [finish](std::string_view v) {
            finish().curvature_reach = parse_double(v, "--quadric-curvature-reach");
          });
  p.value("quadric-min-k", "N",
          "Neighbours of the pilot quadric of --quadric-curvature-reach (>= 10). " +
              finish_default("quadric_min_k") + ".",
          [finish](std::string_view v) { finish().min_k = parse_int(v, "--quadric-min-k"); });
  p.value("quadric-share", "N",
          "Fit sharing: 1 point in N (drawn by its index in the input) fits its own cubic; the "
          "others move onto the fit of the nearest such point on their face among their "
          "--quadric-min-k nearest across which the surface turns by at most "
          "--quadric-share-turn, or fit their own (1..64; 1: every point fits its own). " + finish_default("quadric_share") + ".",
          [finish](std::string_view v) { finish().share_stride = parse_int(v, "--quadric-share"); });
  p.value("quadric-share-turn", "RADIANS",
          "Largest turn of the surface (curvature times distance) across which a fit is "
          "shared (>= 0). " + finish_default("quadric_share_turn") + ".",
          [finish](std::string_view v) { finish().share_turn = parse_double(v, "--quadric-share-turn"); });
  p.group(before);
}

void add_output_options(ArgumentParser& p, OutputOptions& o, bool with_attributes_flag) {
  const OptionGroup before = p.current_group();
  p.group(OptionGroup::Common);
  p.value("colour-by", "kmax|laplacian|none",
          "Colour points (red/green/blue) by the maximal principal curvature max(|k1|, |k2|) or "
          "by |A_i|, blue (minimum) to red (maximum) as CloudCompare, replacing the input's colours; 'none' "
          "keeps the input's colours. Default none (curvature: kmax for a cloud without colours of "
          "its own; demo: kmax).",
          [&o](std::string_view v) {
            o.colour_by_given = true;
            o.colour_by = parse_choice<ColourBy>(v, "colour-by");
          });
  p.value("colour-clip", "F",
          "Fraction of points clipped at each end of the colour range, in [0, 0.5): 0 maps the "
          "minimum and maximum as the paper does; the default keeps outliers from washing out "
          "the rest. Default 0.01.",
          [&o](std::string_view v) {
            o.colour_clip = parse_double(v, "--colour-clip");
            if (!(o.colour_clip >= 0.0 && o.colour_clip < 0.5)) throw UsageError("--colour-clip must be in [0, 0.5)");
          });
  if (with_attributes_flag)
    p.flag("attributes",
           "Also write nx ny nz k1 k2 d1 d2 mean_curvature laplacian_norm feature_class per point, "
           "after the input's own columns (a text file without a header line gets no header: "
           "the columns follow in this order).",
           [&o] { o.attributes = true; });
  p.value("encoding", "binary|binary-be|ascii",
          "PLY encoding of the output. Default: a PLY input's encoding, else binary (little endian).",
          [&o](std::string_view v) {
            if (v != "binary" && v != "binary-be" && v != "ascii")
              throw UsageError("--encoding must be one of binary, binary-be, ascii, got '" + std::string(v) + "'");
            o.encoding = std::string(v);
          });
  p.flag("json", "Print a machine-readable run summary (JSON) on stdout.", [&o] { o.json = true; });
  p.flag("quiet", "No progress or summary on stderr.", [&o] { o.quiet = true; });
  p.value("threads", "N", "Worker threads; 0 = all cores. Default 0.",
          [&o](std::string_view v) {
            o.threads = parse_int(v, "--threads");
            if (o.threads < 0) throw UsageError("--threads must be >= 0");
          });
  p.group(before);
}

}  // namespace pointfair::cli
