#pragma once
// The method's options, shared by the commands that run it (smooth, curvature, demo).
#include <array>
#include <span>
#include <string>

#include "arguments.hpp"
#include "pointfair/finish/quadric_projection.hpp"
#include "pointfair/io/las.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/smooth_names.hpp"

namespace pointfair::cli {

/// What to colour the output by (Section 5 of the paper).
enum class ColourBy { MaxCurvature, Laplacian, None };

/// --colour-by's names, in the order its messages name them (smooth_names.hpp).
inline constexpr std::array<EnumName<ColourBy>, 3> kColourByNames{
    {{ColourBy::MaxCurvature, "kmax"}, {ColourBy::Laplacian, "laplacian"}, {ColourBy::None, "none"}}};
constexpr std::span<const EnumName<ColourBy>> enum_names(ColourBy) { return kColourByNames; }

struct OutputOptions {
  /// None: the input's own colours, if any, are kept. curvature and demo colour by kmax.
  ColourBy colour_by = ColourBy::None;
  /// --colour-by was given (curvature then colours even a cloud with colours of its own).
  bool colour_by_given = false;
  /// Fraction of points clipped at each end of the colour range (0 = the paper's min-max).
  double colour_clip = 0.01;
  /// Also write normal, k1, k2, d1, d2, H, |A| and feature class per point.
  bool attributes = false;
  /// Prefix of the attribute columns' names (k1 ... feature_class, not the normals):
  /// "scalar_" for a PLY output (attribute_prefix_for), which CloudCompare loads as scalar
  /// fields only under such names; empty elsewhere.
  std::string attribute_prefix;
  /// PLY encoding: "binary", "binary-be", "ascii"; empty: a PLY input's, else "binary".
  std::string encoding;
  /// LAS version, scale, offset and coordinate system of a LAS output (las_options.hpp).
  io::LasWriteOptions las;
  bool json = false;
  bool quiet = false;
  int threads = 0;
};

/// Registers --k, --eps, ..., --feature-gated, --move (everything in SmoothParams but the
/// finish).
void add_method_options(ArgumentParser& parser, SmoothParams& params);
/// Registers --quadric-finish, --no-quadric-finish, --quadric-k, --quadric-angle, ... (the
/// finish of SmoothParams).
void add_finish_options(ArgumentParser& parser, SmoothParams& params);
/// Registers --colour-by, --attributes, --encoding, --json, --quiet, --threads.
void add_output_options(ArgumentParser& parser, OutputOptions& output, bool with_attributes_flag);

std::string to_string(Flow flow);
std::string to_string(Cutoff cutoff);
std::string to_string(NormalEstimator normal);
std::string to_string(FeatureMode mode);
std::string to_string(AngularWeights weights);
std::string to_string(ColourBy colour);
std::string to_string(Placement placement);

}  // namespace pointfair::cli
