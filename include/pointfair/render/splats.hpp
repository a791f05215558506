#pragma once
// Headless pictures of point clouds: orthographic camera presets, the points framed to fill the
// panel, z-buffered splats sized per point (each point's own distance to its 8th nearest
// neighbour, measured in its tangent plane) and oriented by its normal (a disc in the tangent
// plane, drawn as the ellipse it projects to, with its own depth at every pixel), Lambert
// shading with a little ambient light, colours given per point or one uniform colour. Scalar
// colours come from pointfair/common/colour.hpp (blue low, red high) and are explained by a
// legend (legend.hpp) under the panels.
//
// Deterministic: the same clouds and parameters give the same bytes, whatever the threads.
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "pointfair/common/colour.hpp"
#include "pointfair/render/legend.hpp"
#include "pointfair/render/png.hpp"
#include "pointfair/types.hpp"

namespace pointfair::render {

enum class View { Iso, Front, Side, Top, Back };

/// "iso", "front", "side", "top", "back"; throws ParamError otherwise.
View parse_view(const std::string& name);

struct RenderParams {
  int width = 640;
  int height = 640;
  View view = View::Iso;
  /// Extra rotation about the vertical screen axis, degrees (turntable).
  double yaw_degrees = 0.0;
  /// Empty border around the points' projected extent, a fraction of the panel's size on each
  /// side, in 0..0.4. 0 lets the outermost points touch the panel's edges.
  double margin = 0.04;
  /// Splat radius as a multiple of each point's own distance to its 8th nearest neighbour in
  /// its tangent plane (capped at 3 times the median radius, so that a lone outlier stays a
  /// dot). About 0.5 closes an evenly spaced grid, 0.7 a randomly sampled surface (under 1% of
  /// the silhouette open); smaller values show the single points.
  double splat_scale = 0.7;
  /// Lambert shading by the (unsigned) normal; false draws every point in its flat colour.
  bool shade = true;
  /// Share of the light that reaches a splat whatever its normal, in 0..1 (1 = flat colours).
  double ambient = 0.35;
  Rgb background = {255, 255, 255};
  /// Colour of points without colours (the paper's Figure 5 yellow).
  Rgb uniform = {235, 200, 40};

  void validate() const;
};

struct CloudView {
  std::span<const Vec3> points;
  /// One colour per point, or empty for RenderParams::uniform.
  std::span<const Rgb> colours;
  /// One normal per point (sign irrelevant), or empty to estimate them (PCA of 16 neighbours).
  std::span<const Vec3> normals;
};

/// The camera's rotation of a preset (rows: screen right, screen up, toward the viewer).
Eigen::Matrix3d view_rotation(View view, double yaw_degrees = 0.0);

/// The extent of the points of `clouds` on the screen of `rotation`: the box of their (right,
/// up) coordinates, in units of length. Empty when there are no points.
Eigen::AlignedBox2d screen_extent(std::span<const CloudView> clouds, const Eigen::Matrix3d& rotation);

/// Renders `cloud` so that `extent` (a screen box of view_rotation(params.view,
/// params.yaw_degrees), e.g. screen_extent of several clouds) fills the panel less the margin
/// in its larger direction, centred. Pixels no splat covers keep the background.
Image render_cloud(const CloudView& cloud, const Eigen::AlignedBox2d& extent, const RenderParams& params);

/// Side-by-side panels with one camera and one framing (the extent of all clouds together, so
/// that the panels compare), a label above each, and `legend` (if any) under them.
Image render_panels(std::span<const CloudView> clouds, std::span<const std::string> labels,
                    const RenderParams& params, const std::optional<ColourLegend>& legend = std::nullopt);

}  // namespace pointfair::render
