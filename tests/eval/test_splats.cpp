#include "pointfair/render/splats.hpp"

#include <gtest/gtest.h>

#include "pointfair/common/params_error.hpp"

namespace pointfair::render {
namespace {

// A dense square patch in the plane z = 0 seen from the top fills the middle of the picture.
TEST(Splats, TopViewOfASquarePutsPixelsWhereExpected) {
  std::vector<Vec3> points;
  for (int i = 0; i <= 60; ++i)
    for (int j = 0; j <= 60; ++j) points.emplace_back(i / 60.0, j / 60.0, 0.0);
  RenderParams params;
  params.width = params.height = 100;
  params.view = View::Top;
  params.shade = false;
  params.uniform = {200, 0, 0};
  Eigen::AlignedBox3d frame(Vec3(0, 0, 0), Vec3(1, 1, 0));
  const Image image = render_cloud({points, {}, {}}, frame, params);
  // The square spans the frame less a 6% margin on each side.
  EXPECT_EQ(image.at(50, 50), (Rgb{200, 0, 0}));
  EXPECT_EQ(image.at(10, 10), (Rgb{200, 0, 0}));
  EXPECT_EQ(image.at(2, 50), (Rgb{255, 255, 255}));
  EXPECT_EQ(image.at(50, 97), (Rgb{255, 255, 255}));
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
  Eigen::AlignedBox3d frame(Vec3(0, 0, 0), Vec3(1, 1, 0.5));
  const Image image = render_cloud({points, colours, {}}, frame, params);
  EXPECT_EQ(image.at(32, 32), (Rgb{0, 255, 0}));
}

TEST(Splats, PanelsAreSideBySide) {
  std::vector<Vec3> points = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(1, 1, 1)};
  RenderParams params;
  params.width = params.height = 32;
  const std::vector<CloudView> clouds = {{points, {}, {}}, {points, {}, {}}};
  const std::vector<std::string> labels = {"a", "b"};
  const Image image = render_panels(clouds, labels, params);
  EXPECT_EQ(image.width, 64);
  EXPECT_EQ(image.height, 32 + 28);
  EXPECT_THROW(parse_view("diagonal"), ParamError);
}

}  // namespace
}  // namespace pointfair::render
