#include "pointfair/render/legend.hpp"

#include <gtest/gtest.h>

#include "pointfair/render/splats.hpp"
#include "pointfair/shapes/shapes.hpp"

namespace pointfair::render {
namespace {

constexpr Rgb kWhite = {255, 255, 255};

// The first and one-past-last column of the longest run of saturated colours (one channel 255,
// one 0) on row y: the bar.
std::pair<int, int> bar_columns(const Image& image, int y) {
  std::pair<int, int> best = {0, 0};
  int start = -1;
  for (int x = 0; x <= image.width; ++x) {
    bool saturated = false;
    if (x < image.width) {
      const Rgb c = image.at(x, y);
      saturated = std::max({c[0], c[1], c[2]}) == 255 && std::min({c[0], c[1], c[2]}) == 0;
    }
    if (saturated && start < 0) start = x;
    if (!saturated && start >= 0) {
      if (x - start > best.second - best.first) best = {start, x};
      start = -1;
    }
  }
  return best;
}

bool has_ink(const Image& image, int x0, int x1, int y0, int y1) {
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x)
      if (image.at(x, y) != kWhite) return true;
  return false;
}

TEST(Legend, NumbersHaveThreeSignificantDigits) {
  EXPECT_EQ(legend_number(0.0123456), "0.0123");
  EXPECT_EQ(legend_number(23.84), "23.8");
  EXPECT_EQ(legend_number(-1.5), "-1.5");
  EXPECT_EQ(legend_number(1534.0), "1.53e+03");
  EXPECT_EQ(legend_number(0.0), "0");
}

// The bar runs from blue at the low end through cyan, green and yellow to red at the high end,
// with the low value written left of it, the high value right of it, the title above.
TEST(Legend, BarRunsFromBlueToRedBetweenItsValues) {
  Image image(400, legend_height(), kWhite);
  draw_legend(image, 0, 0, 400, {"max |k| (1/length)", 0.25, 17.5});
  const int bar_row = legend_height() - 8 - 8;  // inside the 16-pixel bar
  const auto [x0, x1] = bar_columns(image, bar_row);
  ASSERT_GT(x1 - x0, 100);
  EXPECT_EQ(image.at(x0, bar_row), (Rgb{0, 0, 255})) << "low end blue";
  EXPECT_EQ(image.at(x1 - 1, bar_row), (Rgb{255, 0, 0})) << "high end red";
  const Rgb middle = image.at((x0 + x1 - 1) / 2, bar_row);  // within half a column of green
  EXPECT_EQ(middle[1], 255) << "middle green";
  EXPECT_LE(std::max(middle[0], middle[2]), 8) << "middle green";
  for (int x = x0 + 1; x < x1; ++x) {
    EXPECT_GE(image.at(x, bar_row)[0], image.at(x - 1, bar_row)[0]) << "red never falls, x = " << x;
    EXPECT_LE(image.at(x, bar_row)[2], image.at(x - 1, bar_row)[2]) << "blue never rises, x = " << x;
  }
  EXPECT_TRUE(has_ink(image, 0, x0, bar_row - 4, bar_row + 4)) << "the low value";
  EXPECT_TRUE(has_ink(image, x1, 400, bar_row - 4, bar_row + 4)) << "the high value";
  EXPECT_TRUE(has_ink(image, 0, 400, 0, 20)) << "the title";
  // The two numbers as drawn: "0.25" is 4 characters of 12 pixels, less one spacing.
  EXPECT_EQ(text_width("0.25", 2), 46);
}

// A title too long for the double-size font is drawn at the font's own size, inside the strip.
TEST(Legend, LongTitleShrinksToFit) {
  const std::string title = "mean curvature vector length (1/length)";  // 39 characters
  ASSERT_GT(text_width(title, 2), 300);
  ASSERT_LT(text_width(title, 1), 300 - 16);
  Image image(340, legend_height(), kWhite);
  draw_legend(image, 20, 0, 300, {title, 0.0, 1.0});
  EXPECT_TRUE(has_ink(image, 20, 320, 0, 20));
  EXPECT_FALSE(has_ink(image, 0, 20, 0, legend_height())) << "nothing left of the strip";
  EXPECT_FALSE(has_ink(image, 320, 340, 0, legend_height())) << "nothing right of the strip";
}

// render_panels puts one legend under the panels, and colours drawn with the same range match
// it: the low end of the map is blue.
TEST(Legend, PanelsCarryTheLegendUnderneath) {
  const std::vector<Vec3> points = sample_sphere(2000, 1.0, 3).points;
  const std::vector<CloudView> clouds = {{points, {}, {}}, {points, {}, {}}};
  const std::vector<std::string> labels = {"a", "b"};
  RenderParams params;
  params.width = params.height = 200;
  const Image without = render_panels(clouds, labels, params);
  const Image with = render_panels(clouds, labels, params, ColourLegend{"k (1/m)", -1.0, 2.0});
  ASSERT_EQ(with.width, 400);
  ASSERT_EQ(with.height, without.height + legend_height());
  // The panels are unchanged; the strip under them holds a bar.
  for (int y = 0; y < without.height; y += 7)
    for (int x = 0; x < 400; x += 7) ASSERT_EQ(with.at(x, y), without.at(x, y));
  const int bar_row = with.height - 8 - 8;
  const auto [x0, x1] = bar_columns(with, bar_row);
  EXPECT_GT(x1 - x0, 100);
  EXPECT_EQ(with.at(x0, bar_row), hue_colour(-1.0, -1.0, 2.0));
  EXPECT_EQ(with.at(x1 - 1, bar_row), hue_colour(2.0, -1.0, 2.0));
}

}  // namespace
}  // namespace pointfair::render
