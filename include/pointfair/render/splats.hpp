#pragma once
// Headless pictures of point clouds: orthographic camera presets, z-buffered round splats,
// Lambert shading from the (unsigned) PCA normal, colours by a scalar with the paper's hue map
// (pointfair/colour.hpp) or one uniform colour.
#include <span>
#include <string>
#include <vector>

#include "pointfair/common/colour.hpp"
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
  /// Splat radius as a multiple of the median distance to the 8th nearest neighbour.
  double splat_scale = 0.45;
  /// Lambert shading on (normals from PCA of 16 neighbours when none are given).
  bool shade = true;
  Rgb background = {255, 255, 255};
  /// Colour of points without colours (the paper's Figure 5 yellow).
  Rgb uniform = {235, 200, 40};

  void validate() const;
};

struct CloudView {
  std::span<const Vec3> points;
  /// One colour per point, or empty for RenderParams::uniform.
  std::span<const Rgb> colours;
  /// One normal per point (sign irrelevant), or empty to estimate them.
  std::span<const Vec3> normals;
};

/// The camera's rotation of a preset (rows: screen right, screen up, toward the viewer).
Eigen::Matrix3d view_rotation(View view, double yaw_degrees = 0.0);

/// Renders `cloud` so that `frame` (a world box, e.g. the union of several clouds' boxes) fills
/// the picture with a margin. Pixels no splat covers keep the background.
Image render_cloud(const CloudView& cloud, const Eigen::AlignedBox3d& frame, const RenderParams& params);

/// Side-by-side panels with one shared camera and frame, a label above each.
Image render_panels(std::span<const CloudView> clouds, std::span<const std::string> labels,
                    const RenderParams& params);

}  // namespace pointfair::render
