#include "pointfair/render/splats.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "pointfair/common/params_error.hpp"
#include "pointfair/frames/frame.hpp"
#include "pointfair/neighbors/kd_tree.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"

namespace pointfair::render {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Eigen::Matrix3d rows(const Vec3& right, const Vec3& up, const Vec3& toward) {
  Eigen::Matrix3d r;
  r.row(0) = right.normalized();
  r.row(1) = up.normalized();
  r.row(2) = toward.normalized();
  return r;
}

// Median distance to the 8th nearest neighbour over a strided sample of at most 4096 points.
double typical_spacing(std::span<const Vec3> points) {
  if (points.size() < 9) return 0.0;
  const KdTree tree(points);
  const std::size_t stride = std::max<std::size_t>(1, points.size() / 4096);
  std::vector<double> d;
  Index idx[9];
  double d2[9];
  for (std::size_t i = 0; i < points.size(); i += stride) {
    const int found = tree.nearest(points[i], 9, kInf, idx, d2);
    if (found == 9) d.push_back(std::sqrt(d2[8]));
  }
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
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

Image render_cloud(const CloudView& cloud, const Eigen::AlignedBox3d& frame, const RenderParams& params) {
  params.validate();
  require(cloud.colours.empty() || cloud.colours.size() == cloud.points.size(), "one colour per point expected");
  require(cloud.normals.empty() || cloud.normals.size() == cloud.points.size(), "one normal per point expected");
  Image image(params.width, params.height, params.background);
  if (cloud.points.empty() || frame.isEmpty()) return image;
  const Eigen::Matrix3d rotation = view_rotation(params.view, params.yaw_degrees);
  // Screen extent of the frame box (its 8 corners).
  Eigen::AlignedBox2d screen;
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner = frame.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c));
    screen.extend(Eigen::Vector2d((rotation * corner).head<2>()));
  }
  const double margin = 0.06;
  const double span = std::max(screen.sizes().x() / params.width, screen.sizes().y() / params.height);
  const double scale = (1.0 - 2 * margin) / std::max(span, 1e-300);  // pixels per unit length
  const Eigen::Vector2d centre = screen.center();

  std::vector<Vec3> estimated;
  std::span<const Vec3> normals = cloud.normals;
  if (params.shade && normals.empty()) {
    NeighborParams np;
    np.k = static_cast<int>(std::min<std::size_t>(16, cloud.points.size() - 1));
    np.eps = kInf;
    if (np.k >= 2) {
      const Neighborhoods nb = build_neighborhoods(cloud.points, np);
      estimated.resize(cloud.points.size());
      for (std::size_t i = 0; i < estimated.size(); ++i)
        estimated[i] = compute_frame(cloud.points[i], nb.of(i), cloud.points).normal;
      normals = estimated;
    }
  }
  const double radius_px = std::max(1.0, params.splat_scale * typical_spacing(cloud.points) * scale);
  const int reach = static_cast<int>(std::ceil(radius_px));
  std::vector<double> depth(static_cast<std::size_t>(params.width) * static_cast<std::size_t>(params.height), -kInf);
  const Vec3 light = Vec3(-0.4, 0.6, 1.0).normalized();  // in camera coordinates: upper left, front
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    const Vec3 q = rotation * cloud.points[i];
    const double sx = (q.x() - centre.x()) * scale + 0.5 * params.width;
    const double sy = 0.5 * params.height - (q.y() - centre.y()) * scale;
    Rgb colour = cloud.colours.empty() ? params.uniform : cloud.colours[i];
    if (params.shade && !normals.empty()) {
      Vec3 n = rotation * normals[i];
      if (n.z() < 0) n = -n;  // unsigned normals: face the viewer
      const double lit = 0.35 + 0.65 * std::max(0.0, n.dot(light));
      for (auto& channel : colour) channel = static_cast<std::uint8_t>(std::clamp(channel * lit, 0.0, 255.0));
    }
    const int cx = static_cast<int>(std::floor(sx)), cy = static_cast<int>(std::floor(sy));
    for (int y = cy - reach; y <= cy + reach; ++y) {
      if (y < 0 || y >= params.height) continue;
      for (int x = cx - reach; x <= cx + reach; ++x) {
        if (x < 0 || x >= params.width) continue;
        const double dx = x + 0.5 - sx, dy = y + 0.5 - sy;
        if (dx * dx + dy * dy > radius_px * radius_px) continue;
        const std::size_t o = static_cast<std::size_t>(y) * static_cast<std::size_t>(params.width) + static_cast<std::size_t>(x);
        if (q.z() <= depth[o]) continue;
        depth[o] = q.z();
        image.set(x, y, colour);
      }
    }
  }
  return image;
}

Image render_panels(std::span<const CloudView> clouds, std::span<const std::string> labels,
                    const RenderParams& params) {
  params.validate();
  require(!clouds.empty(), "no clouds to render");
  Eigen::AlignedBox3d frame;
  for (const CloudView& c : clouds)
    for (const Vec3& p : c.points) frame.extend(p);
  const int label_height = labels.empty() ? 0 : 28;
  Image out(params.width * static_cast<int>(clouds.size()), params.height + label_height, params.background);
  for (std::size_t k = 0; k < clouds.size(); ++k) {
    const Image panel = render_cloud(clouds[k], frame, params);
    const int x0 = params.width * static_cast<int>(k);
    blit(out, panel, x0, label_height);
    if (k < labels.size()) draw_text(out, x0 + 8, 6, labels[k], {20, 20, 20}, 2);
  }
  return out;
}

}  // namespace pointfair::render
