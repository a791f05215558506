#include "pointfair/render/splats.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/frames/frame.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"

namespace pointfair::render {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kNormalNeighbours = 16;  // PCA normals, as eval's normal error uses
constexpr int kSpacingNeighbour = 8;   // the splat radius follows the distance to the 8th
constexpr double kRadiusCap = 3.0;     // times the median radius
// A disc seen nearly edge-on still covers this share of its radius across: keeps noisy or
// grazing normals from thinning the splats into slits.
constexpr double kMinFacing = 0.3;
constexpr int kLabelHeight = 28;
constexpr int kLegendWidth = 640;

Eigen::Matrix3d rows(const Vec3& right, const Vec3& up, const Vec3& toward) {
  Eigen::Matrix3d r;
  r.row(0) = right.normalized();
  r.row(1) = up.normalized();
  r.row(2) = toward.normalized();
  return r;
}

struct Splats {
  std::vector<Vec3> normals;  // world coordinates, any sign; empty for screen-facing discs
  std::vector<double> radius;  // units of length
};

// Each point's normal (unless given) and splat radius from one k-nearest search.
Splats splats_of(const CloudView& cloud, const RenderParams& params) {
  Splats s;
  const std::size_t n = cloud.points.size();
  s.radius.assign(n, 0.0);
  if (n < 2) return s;
  NeighborParams np;
  np.k = static_cast<int>(std::min<std::size_t>(kNormalNeighbours, n - 1));
  np.eps = kInf;
  const Neighborhoods nb = build_neighborhoods(cloud.points, np);
  const bool estimate = cloud.normals.empty() && np.k >= 2;
  if (estimate) s.normals.resize(n);
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    double in_plane[kNormalNeighbours];
    for (std::size_t i = begin; i < end; ++i) {
      const auto others = nb.of(i);
      Vec3 normal = Vec3::Zero();
      if (!cloud.normals.empty()) normal = cloud.normals[i].normalized();
      else if (estimate) normal = s.normals[i] = compute_frame(cloud.points[i], others, cloud.points).normal;
      if (!normal.allFinite()) normal = Vec3::Zero();
      // Distances in the tangent plane: a noisy point's neighbours above and below the
      // surface do not blow its splat up.
      const std::size_t m = others.size();
      for (std::size_t j = 0; j < m; ++j) {
        const Vec3 d = cloud.points[others[j]] - cloud.points[i];
        in_plane[j] = (d - d.dot(normal) * normal).norm();
      }
      if (m == 0) continue;
      const std::size_t k = std::min<std::size_t>(kSpacingNeighbour, m) - 1;
      std::nth_element(in_plane, in_plane + k, in_plane + m);
      s.radius[i] = params.splat_scale * in_plane[k];
    }
  });
  if (!cloud.normals.empty()) s.normals.assign(cloud.normals.begin(), cloud.normals.end());
  std::vector<double> sorted = s.radius;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(n / 2), sorted.end());
  const double cap = kRadiusCap * sorted[n / 2];
  for (double& r : s.radius) r = std::min(r, cap);
  return s;
}

}  // namespace

View parse_view(const std::string& name) {
  if (name == "iso") return View::Iso;
  if (name == "front") return View::Front;
  if (name == "side") return View::Side;
  if (name == "top") return View::Top;
  if (name == "back") return View::Back;
  throw ParamError("unknown view '" + name + "' (iso, front, side, top, back)");
}

void RenderParams::validate() const {
  require(width >= 16 && width <= 8192 && height >= 16 && height <= 8192, "picture size must be in 16..8192 pixels");
  require(splat_scale > 0 && splat_scale <= 10, "splat scale must be in (0, 10]");
  require(margin >= 0 && margin <= 0.4, "margin must be in 0..0.4");
  require(ambient >= 0 && ambient <= 1, "ambient light must be in 0..1");
  require(std::isfinite(yaw_degrees), "yaw must be finite");
}

Eigen::Matrix3d view_rotation(View view, double yaw_degrees) {
  // World z is up in every preset except top, which looks down the z axis.
  Eigen::Matrix3d r;
  switch (view) {
    case View::Front: r = rows(Vec3::UnitX(), Vec3::UnitZ(), -Vec3::UnitY()); break;
    case View::Back: r = rows(-Vec3::UnitX(), Vec3::UnitZ(), Vec3::UnitY()); break;
    case View::Side: r = rows(Vec3::UnitY(), Vec3::UnitZ(), Vec3::UnitX()); break;
    case View::Top: r = rows(Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()); break;
    case View::Iso:
    default: {
      const Vec3 toward = Vec3(1.0, -1.3, 0.9).normalized();
      const Vec3 right = Vec3::UnitZ().cross(toward).normalized();
      r = rows(right, toward.cross(right), toward);
    }
  }
  const double a = yaw_degrees * std::numbers::pi / 180.0;
  Eigen::Matrix3d yaw;
  yaw << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
  return yaw * r;
}

Eigen::AlignedBox2d screen_extent(std::span<const CloudView> clouds, const Eigen::Matrix3d& rotation) {
  Eigen::AlignedBox2d box;
  for (const CloudView& c : clouds)
    for (const Vec3& p : c.points)
      if (p.allFinite()) box.extend(Eigen::Vector2d((rotation * p).head<2>()));
  return box;
}

Image render_cloud(const CloudView& cloud, const Eigen::AlignedBox2d& extent, const RenderParams& params) {
  params.validate();
  require(cloud.colours.empty() || cloud.colours.size() == cloud.points.size(), "one colour per point expected");
  require(cloud.normals.empty() || cloud.normals.size() == cloud.points.size(), "one normal per point expected");
  Image image(params.width, params.height, params.background);
  if (cloud.points.empty() || extent.isEmpty()) return image;
  const Eigen::Matrix3d rotation = view_rotation(params.view, params.yaw_degrees);
  // The extent's larger side (relative to the panel's) spans the panel less the margins.
  const double inner = 1.0 - 2.0 * params.margin;
  const double span = std::max(extent.sizes().x() / params.width, extent.sizes().y() / params.height);
  // Pixels per unit length; a single point or a line seen end-on gets an arbitrary scale.
  const double scale = span > 0 ? inner / span : 1.0;
  const Eigen::Vector2d centre = extent.center();

  const Splats splats = splats_of(cloud, params);
  std::vector<double> depth(static_cast<std::size_t>(params.width) * static_cast<std::size_t>(params.height), -kInf);
  const Vec3 light = Vec3(-0.35, 0.45, 1.0).normalized();  // in camera coordinates: upper left, front
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    if (!cloud.points[i].allFinite()) continue;
    const Vec3 q = rotation * cloud.points[i];
    const double sx = (q.x() - centre.x()) * scale + 0.5 * params.width;
    const double sy = 0.5 * params.height - (q.y() - centre.y()) * scale;
    // The normal in camera coordinates, turned toward the viewer (unsigned normals).
    Vec3 n = Vec3::UnitZ();
    if (!splats.normals.empty() && splats.normals[i].allFinite() && splats.normals[i].squaredNorm() > 0) {
      n = (rotation * splats.normals[i]).normalized();
      if (n.z() < 0) n = -n;
    }
    Rgb colour = cloud.colours.empty() ? params.uniform : cloud.colours[i];
    if (params.shade) {
      const double lit = params.ambient + (1.0 - params.ambient) * std::max(0.0, n.dot(light));
      for (auto& channel : colour) channel = static_cast<std::uint8_t>(std::lround(std::clamp(channel * lit, 0.0, 255.0)));
    }
    // A disc of the splat's radius in the point's tangent plane: a pixel is covered when the
    // plane's point under it lies within the radius; its depth is that point's.
    const double nz = std::max(n.z(), kMinFacing);
    const double radius_px = std::max(0.75, splats.radius[i] * scale);
    const double r2 = radius_px * radius_px;
    const int reach = static_cast<int>(std::ceil(radius_px));
    const int cx = static_cast<int>(std::floor(sx)), cy = static_cast<int>(std::floor(sy));
    for (int y = std::max(0, cy - reach); y <= std::min(params.height - 1, cy + reach); ++y) {
      for (int x = std::max(0, cx - reach); x <= std::min(params.width - 1, cx + reach); ++x) {
        const double dx = x + 0.5 - sx, dy = sy - (y + 0.5);  // pixels, screen up positive
        const double dz = -(n.x() * dx + n.y() * dy) / nz;
        if (dx * dx + dy * dy + dz * dz > r2) continue;
        const std::size_t o = static_cast<std::size_t>(y) * static_cast<std::size_t>(params.width) + static_cast<std::size_t>(x);
        const double z = q.z() + dz / scale;
        if (z <= depth[o]) continue;
        depth[o] = z;
        image.set(x, y, colour);
      }
    }
  }
  return image;
}

Image render_panels(std::span<const CloudView> clouds, std::span<const std::string> labels,
                    const RenderParams& params, const std::optional<ColourLegend>& legend) {
  params.validate();
  require(!clouds.empty(), "no clouds to render");
  const Eigen::AlignedBox2d extent = screen_extent(clouds, view_rotation(params.view, params.yaw_degrees));
  const int label_height = labels.empty() ? 0 : kLabelHeight;
  const int legend_rows = legend ? legend_height() : 0;
  const int width = params.width * static_cast<int>(clouds.size());
  Image out(width, label_height + params.height + legend_rows, params.background);
  for (std::size_t k = 0; k < clouds.size(); ++k) {
    const Image panel = render_cloud(clouds[k], extent, params);
    const int x0 = params.width * static_cast<int>(k);
    blit(out, panel, x0, label_height);
    if (k < labels.size()) draw_text(out, x0 + 8, 6, labels[k], {20, 20, 20}, 2);
  }
  if (legend) {
    // Centred, as wide as one panel but at least kLegendWidth (less if the picture is smaller).
    const int legend_width = std::min(width, std::max(params.width, kLegendWidth));
    draw_legend(out, (width - legend_width) / 2, label_height + params.height, legend_width, *legend);
  }
  return out;
}

}  // namespace pointfair::render
