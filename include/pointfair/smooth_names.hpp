#pragma once
// The names of the smoothing parameters' choices, one table per enum: what the command line
// parses and prints, the --json summary writes and an out-of-core run stores in its file's
// attributes. A name differs between those places only where the table says so (`stored`).
#include <array>
#include <optional>
#include <span>
#include <string_view>

#include "pointfair/curvature/curvature.hpp"
#include "pointfair/curvature/features.hpp"
#include "pointfair/flow/euler_step.hpp"
#include "pointfair/flow/laplacian.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair {

template <class Enum>
struct EnumName {
  Enum value;
  /// The name the command line takes and prints (and the --json summary writes).
  std::string_view name;
  /// The name in an out-of-core run's file attributes, where it differs from `name`; empty:
  /// the same.
  std::string_view stored = {};
};

// Each table lists its choices in the order the command line's messages name them.
inline constexpr std::array<EnumName<Flow>, 2> kFlowNames{{{Flow::Isotropic, "iso"}, {Flow::Anisotropic, "aniso"}}};
inline constexpr std::array<EnumName<Cutoff>, 2> kCutoffNames{
    {{Cutoff::Sharp, "sharp"}, {Cutoff::Continuous, "continuous"}}};
inline constexpr std::array<EnumName<CutoffOrigin>, 2> kCutoffOriginNames{
    {{CutoffOrigin::Point, "point"}, {CutoffOrigin::Plane, "plane"}}};
inline constexpr std::array<EnumName<NormalEstimator>, 2> kNormalEstimatorNames{
    {{NormalEstimator::Pca, "pca"}, {NormalEstimator::Robust, "robust"}}};
inline constexpr std::array<EnumName<FeatureMode>, 3> kFeatureModeNames{
    {{FeatureMode::None, "none"}, {FeatureMode::EdgeQuotient, "quotient"}, {FeatureMode::MaxCurvature, "maxcurv"}}};
inline constexpr std::array<EnumName<FeatureScale>, 2> kFeatureScaleNames{
    {{FeatureScale::Spacing, "spacing"}, {FeatureScale::Lambda, "lambda"}}};
inline constexpr std::array<EnumName<AngularWeights>, 2> kAngularWeightsNames{
    {{AngularWeights::Paper, "paper"}, {AngularWeights::Uniform, "uniform"}}};
inline constexpr std::array<EnumName<Placement>, 2> kPlacementNames{
    {{Placement::AlongNormal, "normal", "along_normal"}, {Placement::Free, "free"}}};

/// The table of an enum, found by overload on a value of it.
constexpr std::span<const EnumName<Flow>> enum_names(Flow) { return kFlowNames; }
constexpr std::span<const EnumName<Cutoff>> enum_names(Cutoff) { return kCutoffNames; }
constexpr std::span<const EnumName<CutoffOrigin>> enum_names(CutoffOrigin) { return kCutoffOriginNames; }
constexpr std::span<const EnumName<NormalEstimator>> enum_names(NormalEstimator) { return kNormalEstimatorNames; }
constexpr std::span<const EnumName<FeatureMode>> enum_names(FeatureMode) { return kFeatureModeNames; }
constexpr std::span<const EnumName<FeatureScale>> enum_names(FeatureScale) { return kFeatureScaleNames; }
constexpr std::span<const EnumName<AngularWeights>> enum_names(AngularWeights) { return kAngularWeightsNames; }
constexpr std::span<const EnumName<Placement>> enum_names(Placement) { return kPlacementNames; }

/// The command line's name of `value`; "?" for a value outside its enum.
template <class Enum>
constexpr std::string_view name_of(Enum value) {
  for (const EnumName<Enum>& e : enum_names(value))
    if (e.value == value) return e.name;
  return "?";
}

/// The name of `value` in an out-of-core run's file attributes.
template <class Enum>
constexpr std::string_view stored_name_of(Enum value) {
  for (const EnumName<Enum>& e : enum_names(value))
    if (e.value == value) return e.stored.empty() ? e.name : e.stored;
  return "?";
}

/// The value the command line's name `name` stands for; empty for none.
template <class Enum>
constexpr std::optional<Enum> enum_from_name(std::string_view name) {
  for (const EnumName<Enum>& e : enum_names(Enum{}))
    if (e.name == name) return e.value;
  return std::nullopt;
}

}  // namespace pointfair
