#pragma once
// The smoothing parameters' table (SmoothParams but the finish, whose table is
// finish/quadric_parameters.hpp): one entry per parameter with its names in the resume key of
// an out-of-core run, the --json summary's "parameters" block and the run file's attributes,
// and its value. The table is in the resume key's order; the --json block and the attributes
// have orders of their own (kSmoothJsonOrder, kSmoothStoredOrder), checked to cover it. The
// forms were written by hand before the table and keep their names and orders, so that run
// files resume and summaries read as before.
#include <array>
#include <string_view>

#include "pointfair/common/parameter.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/smooth_names.hpp"

namespace pointfair {

using SmoothParameter = Parameter<SmoothParams>;

/// A choice's value by its enum's table (smooth_names.hpp).
template <class Enum>
constexpr ParameterValue choice(Enum v) {
  return choice_value(v, name_of(v), stored_name_of(v));
}

/// Whether features are found by the spacing rule (FeatureScale::Spacing with no fixed
/// threshold), which the resume key names.
constexpr bool spacing_feature_rule(const SmoothParams& p) {
  return p.flow.features.threshold == 0.0 && p.flow.features.scale == FeatureScale::Spacing;
}

// Entries without a --json name are written there by the summary itself: the k, eps and
// lambda the run used rather than those asked for, and the feature threshold's rule.
inline constexpr std::array<SmoothParameter, 31> kSmoothParameters{{
    {"k", "", "k", [](const SmoothParams& p) { return integer_value(p.neighbors.k); }},
    {"eps", "", "eps_requested", [](const SmoothParams& p) { return real_value(p.neighbors.eps); }},
    {"eps_factor", "", "eps_factor", [](const SmoothParams& p) { return real_value(p.neighbors.eps_auto_factor); }},
    {"steps", "steps", "steps", [](const SmoothParams& p) { return integer_value(p.steps); }},
    {"rebuild", "rebuild_every", "", [](const SmoothParams& p) { return integer_value(p.rebuild_interval); }},
    {"lambda_every_step", "lambda_every_step", "lambda_every_step",
     [](const SmoothParams& p) { return flag_value(p.lambda_every_step); }},
    {"flow", "flow", "flow", [](const SmoothParams& p) { return choice(p.flow.flow); }},
    {"cutoff", "cutoff", "cutoff", [](const SmoothParams& p) { return choice(p.flow.cutoff); }},
    {"lambda", "", "lambda_requested", [](const SmoothParams& p) { return real_value(p.flow.lambda); }},
    {"lambda_factor", "lambda_factor", "lambda_factor",
     [](const SmoothParams& p) { return real_value(p.flow.lambda_auto_factor); }},
    {"tau", "tau", "tau", [](const SmoothParams& p) { return real_value(p.flow.tau); }},
    {"constrain_normal", "constrain_normal", "constrain_normal",
     [](const SmoothParams& p) { return flag_value(p.flow.constrain_normal); }},
    {"feature_gated", "feature_gated", "feature_gated", [](const SmoothParams& p) { return flag_value(p.flow.feature_gated); }},
    {"features", "features", "features", [](const SmoothParams& p) { return choice(p.flow.features.mode); }},
    {"quotient", "edge_quotient", "edge_quotient", [](const SmoothParams& p) { return real_value(p.flow.features.quotient); }},
    {"feature_threshold", "", "feature_threshold",
     [](const SmoothParams& p) { return real_value(p.flow.features.threshold); }},
    {"weights", "weights", "weights", [](const SmoothParams& p) { return choice(p.flow.weingarten.weights); }},
    {"density_floor", "density_floor", "density_floor",
     [](const SmoothParams& p) { return real_value(p.flow.weingarten.density_floor); }},
    {"cutoff_origin", "cutoff_origin", "", [](const SmoothParams& p) { return choice(p.flow.cutoff_origin); }},
    {"stop_lambda_ratio", "stop_lambda_ratio", "", [](const SmoothParams& p) { return real_value(p.stop_lambda_ratio); }},
    {"normal", "normal", "normal", [](const SmoothParams& p) { return choice(p.flow.normal_estimator); }},
    {"robust_seed", "robust_seed", "", [](const SmoothParams& p) { return integer_value(p.flow.robust.seed_neighbors); }},
    {"robust_iterations", "robust_iterations", "",
     [](const SmoothParams& p) { return integer_value(p.flow.robust.iterations); }},
    {"robust_bound", "robust_bound", "", [](const SmoothParams& p) { return real_value(p.flow.robust.inlier_bound); }},
    // Named in the key only when on: runs started before these options existed still resume.
    {"stop_plateau", "stop_plateau", "", [](const SmoothParams& p) { return real_value(p.stop_plateau); },
     [](const SmoothParams& p) { return p.stop_plateau != 0.0; }},
    {"shrink_compensation", "shrink_compensation", "",
     [](const SmoothParams& p) { return real_value(p.shrink_compensation); },
     [](const SmoothParams& p) { return p.shrink_compensation != 0.0; }},
    // Runs from before the spacing rule classified by lambda: they resume with
    // --feature-threshold lambda (no name in the key), not with the rule that would change
    // their classes.
    {"feature_scale", "", "feature_scale", [](const SmoothParams& p) { return choice(p.flow.features.scale); },
     [](const SmoothParams& p) { return spacing_feature_rule(p); }, true},
    {"feature_turn", "", "feature_turn", [](const SmoothParams& p) { return real_value(p.flow.features.turn); },
     [](const SmoothParams& p) { return spacing_feature_rule(p); }},
    // Runs from before the gate fitted the robust plane at every point: they resume with
    // --robust-gate 0.
    {"robust_gate", "robust_gate", "", [](const SmoothParams& p) { return real_value(p.flow.robust.gate); },
     [](const SmoothParams& p) { return p.flow.robust.gate != 0.0; }},
    {"momentum", "momentum", "", [](const SmoothParams& p) { return real_value(p.momentum); },
     [](const SmoothParams& p) { return has_momentum(p); }},
    {"momentum_gate", "momentum_gate", "", [](const SmoothParams& p) { return real_value(p.momentum_gate); },
     [](const SmoothParams& p) { return has_momentum(p); }},
}};

/// The --json "parameters" block's order: the table's --json names and, where the summary
/// writes them itself, "k", "k_auto", "eps", "lambda", "lambda_auto", "feature_threshold" and
/// "feature_turn".
inline constexpr std::array<std::string_view, 31> kSmoothJsonOrder{
    "k",           "k_auto",        "eps",           "steps",          "tau",               "flow",
    "cutoff",      "lambda",        "lambda_auto",   "lambda_factor",  "lambda_every_step", "constrain_normal",
    "rebuild_every", "features",    "edge_quotient", "feature_threshold", "feature_turn",   "feature_gated",
    "weights",     "density_floor", "cutoff_origin", "stop_lambda_ratio", "stop_plateau",   "shrink_compensation",
    "momentum",    "momentum_gate", "normal",      "robust_seed",   "robust_iterations", "robust_bound", "robust_gate"};
static_assert(covers<SmoothParams>(kSmoothParameters, &SmoothParameter::json, kSmoothJsonOrder));

/// The run file's attributes' order.
inline constexpr std::array<std::string_view, 20> kSmoothStoredOrder{
    "k",           "eps_requested",    "eps_factor",      "steps",         "tau",
    "flow",        "cutoff",           "lambda_requested", "lambda_factor", "lambda_every_step",
    "constrain_normal", "feature_gated", "features",      "edge_quotient", "feature_threshold",
    "feature_scale", "feature_turn",   "weights",         "density_floor", "normal"};
static_assert(covers<SmoothParams>(kSmoothParameters, &SmoothParameter::stored, kSmoothStoredOrder));
static_assert(names_only_entries<SmoothParams>(kSmoothParameters, &SmoothParameter::stored, kSmoothStoredOrder));

}  // namespace pointfair
