#include "pointfair/render/splats.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/shapes/shapes.hpp"

namespace pointfair::render {
namespace {

constexpr Rgb kWhite = {255, 255, 255};

// The box of the pixels that differ from `background`, as {x0, y0, x1, y1} (inclusive); x1 < x0
// when there are none.
std::array<int, 4> ink_box(const Image& image, Rgb background, int y_begin = 0, int y_end = -1) {
  if (y_end < 0) y_end = image.height;
  std::array<int, 4> box = {image.width, image.height, -1, -1};
  for (int y = y_begin; y < y_end; ++y)
    for (int x = 0; x < image.width; ++x)
      if (image.at(x, y) != background) {
        box[0] = std::min(box[0], x);
        box[1] = std::min(box[1], y);
        box[2] = std::max(box[2], x);
        box[3] = std::max(box[3], y);
      }
  return box;
}

Image render_one(const CloudView& cloud, const RenderParams& params) {
  return render_cloud(cloud, screen_extent(std::span(&cloud, 1), view_rotation(params.view, params.yaw_degrees)),
                      params);
}

// Share of the pixels inside a convex object's silhouette (between the object's first and last
// pixel on both the pixel's row and its column) that show the background.
double convex_hole_fraction(const Image& image, Rgb background) {
  const int w = image.width, h = image.height;
  std::vector<int> row_first(h, w), row_last(h, -1), col_first(w, h), col_last(w, -1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (image.at(x, y) != background) {
        row_first[y] = std::min(row_first[y], x);
        row_last[y] = std::max(row_last[y], x);
        col_first[x] = std::min(col_first[x], y);
        col_last[x] = std::max(col_last[x], y);
      }
  long inside = 0, holes = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (x < row_first[y] || x > row_last[y] || y < col_first[x] || y > col_last[x]) continue;
      ++inside;
      if (image.at(x, y) == background) ++holes;
    }
  return inside == 0 ? 1.0 : static_cast<double>(holes) / static_cast<double>(inside);
}

// A dense square patch in the plane z = 0 seen from the top fills the panel less the margin.
TEST(Splats, TopViewOfASquarePutsPixelsWhereExpected) {
  std::vector<Vec3> points;
  for (int i = 0; i <= 60; ++i)
    for (int j = 0; j <= 60; ++j) points.emplace_back(i / 60.0, j / 60.0, 0.0);
  RenderParams params;
  params.width = params.height = 100;
  params.view = View::Top;
  params.margin = 0.1;
  params.shade = false;
  params.uniform = {200, 0, 0};
  const Image image = render_cloud({points, {}, {}}, Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1)), params);
  // The square spans pixels 10..90 (splats reach a pixel or two further).
  EXPECT_EQ(image.at(50, 50), (Rgb{200, 0, 0}));
  EXPECT_EQ(image.at(11, 11), (Rgb{200, 0, 0}));
  EXPECT_EQ(image.at(88, 88), (Rgb{200, 0, 0}));
  EXPECT_EQ(image.at(4, 50), kWhite);
  EXPECT_EQ(image.at(50, 95), kWhite);
}

TEST(Splats, ZBufferKeepsTheNearerLayer) {
  std::vector<Vec3> points;
  std::vector<Rgb> colours;
  for (int layer = 0; layer < 2; ++layer)
    for (int i = 0; i <= 40; ++i)
      for (int j = 0; j <= 40; ++j) {
        points.emplace_back(i / 40.0, j / 40.0, layer == 0 ? 0.0 : 0.5);
        colours.push_back(layer == 0 ? Rgb{0, 0, 255} : Rgb{0, 255, 0});
      }
  RenderParams params;
  params.width = params.height = 64;
  params.view = View::Top;  // looking down: z = 0.5 is nearer
  params.shade = false;
  const Image image = render_one({points, colours, {}}, params);
  for (int y = 8; y < 56; y += 4)
    for (int x = 8; x < 56; x += 4) EXPECT_EQ(image.at(x, y), (Rgb{0, 255, 0})) << x << ", " << y;
}

// Framing: the points' projected extent, not their 3-D box, fills the panel (the iso view of
// an octahedron used to fill half of it), centred.
TEST(Splats, TheCloudFillsThePanelInItsLargerDirection) {
  const std::vector<Vec3> points = mesh_vertices(subdivide_4_1(octahedron_mesh(), 4)).points;
  for (const View view : {View::Iso, View::Front, View::Top}) {
    RenderParams params;
    params.width = 200;
    params.height = 160;
    params.view = view;
    const Image image = render_one({points, {}, {}}, params);
    const auto box = ink_box(image, params.background);
    const double fill_x = (box[2] - box[0] + 1) / 200.0, fill_y = (box[3] - box[1] + 1) / 160.0;
    EXPECT_GE(std::max(fill_x, fill_y), 0.9) << "view " << static_cast<int>(view);
    EXPECT_LE(std::max(fill_x, fill_y), 1.0);
    EXPECT_NEAR(box[0] + box[2], 200 - 1, 4) << "centred across";
    EXPECT_NEAR(box[1] + box[3], 160 - 1, 4) << "centred down";
  }
}

// Panels share one framing: a cloud half the size of its neighbour is drawn half as large,
// and the larger one fills its panel.
TEST(Splats, PanelsShareOneFraming) {
  const std::vector<Vec3> big = sample_sphere(4000, 1.0, 3).points;
  std::vector<Vec3> small = big;
  for (Vec3& p : small) p *= 0.5;
  RenderParams params;
  params.width = params.height = 120;
  params.view = View::Front;
  const std::vector<CloudView> clouds = {{big, {}, {}}, {small, {}, {}}};
  const std::vector<std::string> labels = {"big", "small"};
  const Image image = render_panels(clouds, labels, params);
  ASSERT_EQ(image.width, 240);
  ASSERT_EQ(image.height, 120 + 28);
  Image left(120, 120, kWhite), right(120, 120, kWhite);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 120; ++x) {
      left.set(x, y, image.at(x, 28 + y));
      right.set(x, y, image.at(120 + x, 28 + y));
    }
  const auto a = ink_box(left, kWhite), b = ink_box(right, kWhite);
  EXPECT_GE(a[2] - a[0] + 1, 0.8 * 120);
  EXPECT_NEAR(b[2] - b[0] + 1, 0.5 * (a[2] - a[0] + 1), 4);
  EXPECT_GT(ink_box(image, kWhite, 0, 28)[2], 120) << "the second panel's label";
}

// Splats sized by each point's own spacing close a randomly sampled surface: seen from the
// front, with the near half of a sphere green and the far half red, almost no pixel inside
// the silhouette shows the background or the far half through a gap. (The old fixed splats,
// 0.45 x the median 8th-neighbour distance, left 10-11% of this disc open.)
TEST(Splats, SplatsCloseADenseSampledSurface) {
  for (const std::size_t n : {5000u, 40000u}) {
    const std::vector<Vec3> points = sample_sphere(n, 1.0, 7).points;
    std::vector<Rgb> colours;
    for (const Vec3& p : points) colours.push_back(p.y() < 0 ? Rgb{0, 200, 0} : Rgb{200, 0, 0});
    RenderParams params;
    params.width = params.height = 400;
    params.view = View::Front;  // looking along +y: y < 0 is the near half
    params.shade = false;
    const Image image = render_one({points, colours, {}}, params);
    // The sphere's outline is the disc of radius (1 - 2 margin) x 200 about the centre; the
    // last 2 pixels of it are left out (splats there are seen edge-on).
    const double radius = (1.0 - 2.0 * params.margin) * 200.0 - 2.0;
    long inside = 0, open = 0;
    for (int y = 0; y < 400; ++y)
      for (int x = 0; x < 400; ++x) {
        const double dx = x + 0.5 - 200.0, dy = y + 0.5 - 200.0;
        if (dx * dx + dy * dy > radius * radius) continue;
        ++inside;
        if (image.at(x, y) != Rgb{0, 200, 0}) ++open;
      }
    EXPECT_LT(static_cast<double>(open) / static_cast<double>(inside), 0.01) << n << " points";
  }
  // Area samples of a cube seen from a corner: flat faces and sharp edges.
  RenderParams params;
  params.width = params.height = 400;
  const std::vector<Vec3> cube = sample_mesh(cube_mesh(), 20000, 3).points;
  EXPECT_LT(convex_hole_fraction(render_one({cube, {}, {}}, params), params.background), 0.01);
}

// Lambert shading with ambient light: on a sphere lit from the upper left, the upper left is
// bright, the lower right gets the ambient share only, and flat rendering is uniform.
TEST(Splats, ShadingFollowsTheNormal) {
  const std::vector<Vec3> points = sample_sphere(20000, 1.0, 5).points;
  RenderParams params;
  params.width = params.height = 200;
  params.view = View::Front;
  params.uniform = {200, 200, 200};
  params.ambient = 0.25;
  const Image lit = render_one({points, {}, {}}, params);
  // The light (-0.35, 0.45, 1) / 1.15 in camera coordinates is the normal of the sphere's
  // point at pixel (100 - 0.30 x 92, 100 - 0.39 x 92) (the sphere's radius is 92 pixels); at
  // (160, 160) the normal faces away from it.
  const Rgb bright = lit.at(72, 64), dark = lit.at(160, 160);
  EXPECT_GE(bright[0], 190);
  EXPECT_LE(dark[0], 90);
  EXPECT_GE(dark[0], 45) << "ambient";
  params.shade = false;
  const Image flat = render_one({points, {}, {}}, params);
  EXPECT_EQ(flat.at(72, 64), (Rgb{200, 200, 200}));
  EXPECT_EQ(flat.at(160, 160), (Rgb{200, 200, 200}));
}

TEST(Splats, SameInputSameBytesWhateverTheThreads) {
  const std::vector<Vec3> points = sample_mesh(cube_mesh(), 6000, 9).points;
  RenderParams params;
  params.width = params.height = 96;
  set_thread_count(1);
  const Image one = render_one({points, {}, {}}, params);
  set_thread_count(2);
  const Image two = render_one({points, {}, {}}, params);
  set_thread_count(0);
  EXPECT_EQ(one.rgb, two.rgb);
  EXPECT_EQ(encode_png(one), encode_png(render_one({points, {}, {}}, params)));
}

TEST(Splats, ParametersAreChecked) {
  EXPECT_THROW(parse_view("diagonal"), ParamError);
  RenderParams params;
  params.margin = 0.5;
  EXPECT_THROW(params.validate(), ParamError);
  params = {};
  params.ambient = 1.5;
  EXPECT_THROW(params.validate(), ParamError);
  params = {};
  params.splat_scale = 0;
  EXPECT_THROW(params.validate(), ParamError);
  const std::vector<Vec3> points = {Vec3(0, 0, 0)};
  const std::vector<Rgb> two_colours(2);
  EXPECT_THROW(render_one({points, two_colours, {}}, RenderParams{}), ParamError);
  // One point: a dot in the middle, no division by a zero extent.
  const Image dot = render_one({points, {}, {}}, RenderParams{});
  EXPECT_NE(dot.at(320, 320), kWhite);
}

}  // namespace
}  // namespace pointfair::render
