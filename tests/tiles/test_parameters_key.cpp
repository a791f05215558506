// The resume key from the parameter tables (smooth_parameters.hpp, quadric_parameters.hpp) is
// the line written by hand before them, to the byte: run files made then still resume. The
// reference below is that hand-written line.
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "pointfair/smooth.hpp"
#include "pointfair/smooth_names.hpp"
#include "run.hpp"

using namespace pointfair;

namespace {

std::string reference_parameters_key(const SmoothParams& p) {
  std::ostringstream s;
  s.precision(17);
  s << "k=" << p.neighbors.k << " eps=" << p.neighbors.eps << " eps_factor=" << p.neighbors.eps_auto_factor
    << " steps=" << p.steps << " rebuild=" << p.rebuild_interval << " lambda_every_step=" << p.lambda_every_step
    << " flow=" << static_cast<int>(p.flow.flow) << " cutoff=" << static_cast<int>(p.flow.cutoff)
    << " lambda=" << p.flow.lambda << " lambda_factor=" << p.flow.lambda_auto_factor << " tau=" << p.flow.tau
    << " constrain_normal=" << p.flow.constrain_normal << " feature_gated=" << p.flow.feature_gated
    << " features=" << static_cast<int>(p.flow.features.mode) << " quotient=" << p.flow.features.quotient
    << " feature_threshold=" << p.flow.features.threshold << " weights=" << static_cast<int>(p.flow.weingarten.weights)
    << " density_floor=" << p.flow.weingarten.density_floor << " cutoff_origin=" << static_cast<int>(p.flow.cutoff_origin)
    << " stop_lambda_ratio=" << p.stop_lambda_ratio << " normal=" << static_cast<int>(p.flow.normal_estimator)
    << " robust_seed=" << p.flow.robust.seed_neighbors << " robust_iterations=" << p.flow.robust.iterations
    << " robust_bound=" << p.flow.robust.inlier_bound;
  if (p.stop_plateau != 0.0) s << " stop_plateau=" << p.stop_plateau;
  if (p.shrink_compensation != 0.0) s << " shrink_compensation=" << p.shrink_compensation;
  if (p.flow.features.threshold == 0.0 && p.flow.features.scale == FeatureScale::Spacing)
    s << " feature_scale=spacing feature_turn=" << p.flow.features.turn;
  if (p.flow.robust.gate != 0.0) s << " robust_gate=" << p.flow.robust.gate;
  if (has_momentum(p)) s << " momentum=" << p.momentum << " momentum_gate=" << p.momentum_gate;
  return s.str();
}

std::string reference_finish_key(const QuadricProjectionParams& q) {
  std::ostringstream s;
  s.precision(17);
  s << "quadric_k=" << q.k << " quadric_normal_neighbors=" << q.normal_neighbors << " quadric_angle=" << q.normal_angle
    << " quadric_iterations=" << q.iterations << " quadric_bound=" << q.inlier_bound << " quadric_degree=" << q.degree
    << " quadric_passes=" << q.passes << " quadric_curvature_reach=" << q.curvature_reach
    << " quadric_min_k=" << q.min_k << " quadric_frame_seed=" << q.frame.seed_neighbors
    << " quadric_frame_iterations=" << q.frame.iterations << " quadric_frame_bound=" << q.frame.inlier_bound
    << " quadric_placement_turn=" << q.placement_turn;
  if (q.share_stride != 1) s << " quadric_share=" << q.share_stride << " quadric_share_turn=" << q.share_turn;
  if (q.passes > 1 && (q.early_degree != q.degree || q.early_iterations != q.iterations))
    s << " quadric_early_degree=" << q.early_degree << " quadric_early_iterations=" << q.early_iterations;
  return s.str();
}

TEST(ParametersKey, TheTablesWriteTheLineWrittenByHand) {
  SmoothParams changed;
  changed.neighbors.k = 0;
  changed.neighbors.eps = 0.123456789;
  changed.steps = 7;
  changed.rebuild_interval = 3;
  changed.lambda_every_step = false;
  changed.flow.flow = Flow::Isotropic;
  changed.flow.cutoff = Cutoff::Continuous;
  changed.flow.lambda = 1.0 / 3.0;
  changed.flow.constrain_normal = true;
  changed.flow.feature_gated = true;
  changed.flow.features.mode = FeatureMode::MaxCurvature;
  changed.flow.weingarten.weights = AngularWeights::Uniform;
  changed.flow.cutoff_origin = CutoffOrigin::Point;
  changed.flow.normal_estimator = NormalEstimator::Pca;
  changed.stop_plateau = 0.0;
  changed.shrink_compensation = 0.0;
  changed.flow.robust.gate = 0.0;
  SmoothParams fixed_threshold;
  fixed_threshold.flow.features.threshold = 2.5;
  SmoothParams lambda_rule;
  lambda_rule.flow.features.scale = FeatureScale::Lambda;
  for (const SmoothParams& p : {SmoothParams{}, paper_smooth_params(SmoothParams{}), changed, fixed_threshold, lambda_rule}) {
    EXPECT_EQ(tiles::detail::parameters_key(p), reference_parameters_key(p));
    // Runs from before momentum (or where no step can have it) name none of it.
    SmoothParams without = p;
    without.momentum = 0.0;
    EXPECT_EQ(tiles::detail::parameters_key(without).find("momentum"), std::string::npos);
    QuadricProjectionParams q = p.finish.value_or(QuadricProjectionParams{});
    EXPECT_EQ(tiles::detail::finish_key(q), reference_finish_key(q));
    // Runs from before fit sharing (every point its own fit) name none of it.
    q.share_stride = 1;
    EXPECT_EQ(tiles::detail::finish_key(q), reference_finish_key(q));
    EXPECT_EQ(tiles::detail::finish_key(q).find("share"), std::string::npos);
  }
}

TEST(EnumNames, EveryChoiceRoundTrips) {
  for (const Flow v : {Flow::Isotropic, Flow::Anisotropic}) EXPECT_EQ(enum_from_name<Flow>(name_of(v)), v);
  for (const FeatureMode v : {FeatureMode::None, FeatureMode::EdgeQuotient, FeatureMode::MaxCurvature})
    EXPECT_EQ(enum_from_name<FeatureMode>(name_of(v)), v);
  EXPECT_EQ(name_of(Placement::AlongNormal), "normal");
  EXPECT_EQ(stored_name_of(Placement::AlongNormal), "along_normal");
  EXPECT_EQ(stored_name_of(Flow::Anisotropic), "aniso");
  EXPECT_FALSE(enum_from_name<Cutoff>("blunt"));
}

}  // namespace
