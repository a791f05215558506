// Colouring by a scalar: blue low, red high (as CloudCompare): hue 240 degrees at the minimum
// down to 0 at the maximum, full saturation and value, linear in the scalar.
#include "pointfair/common/colour.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace pointfair {
namespace {

// Hue in degrees of a fully saturated colour (max channel 255, min channel 0).
double hue_degrees(const Rgb& c) {
  const double r = c[0] / 255.0, g = c[1] / 255.0, b = c[2] / 255.0;
  const double hi = std::max({r, g, b}), lo = std::min({r, g, b});
  const double span = hi - lo;
  double h = 0.0;
  if (span == 0.0) return 0.0;
  if (hi == r) h = 60.0 * std::fmod((g - b) / span + 6.0, 6.0);
  else if (hi == g) h = 60.0 * ((b - r) / span + 2.0);
  else h = 60.0 * ((r - g) / span + 4.0);
  return h;
}

// One byte step of one channel moves the hue by 60/255 degrees.
constexpr double kHueQuantum = 60.0 / 255.0;

TEST(Colour, EndsOfTheScale) {
  EXPECT_EQ(hue_colour(2.0, 2.0, 5.0), (Rgb{0, 0, 255})) << "the minimum is blue";
  EXPECT_EQ(hue_colour(5.0, 2.0, 5.0), (Rgb{255, 0, 0})) << "the maximum is red";
  // Sextant boundaries: cyan at a quarter, green at half, yellow at three quarters.
  EXPECT_EQ(hue_colour(1.0, 0.0, 4.0), (Rgb{0, 255, 255}));
  EXPECT_EQ(hue_colour(2.0, 0.0, 4.0), (Rgb{0, 255, 0}));
  EXPECT_EQ(hue_colour(3.0, 0.0, 4.0), (Rgb{255, 255, 0}));
  // Half-way from blue to cyan: green = 127.5 rounds to 128.
  EXPECT_EQ(hue_colour(0.5, 0.0, 4.0), (Rgb{0, 128, 255}));
}

TEST(Colour, HueIsLinearAndMonotone) {
  double previous = 240.0;
  for (int i = 0; i <= 2000; ++i) {
    const double t = i / 2000.0;
    const Rgb c = hue_colour(-1.0 + 3.0 * t, -1.0, 2.0);
    const double h = hue_degrees(c);
    EXPECT_LE(h, previous + 1e-9) << "t = " << t;
    EXPECT_NEAR(h, 240.0 * (1.0 - t), kHueQuantum) << "linear in the scalar, t = " << t;
    // Full saturation and value: one channel at 255, one at 0.
    EXPECT_EQ(std::max({c[0], c[1], c[2]}), 255);
    EXPECT_EQ(std::min({c[0], c[1], c[2]}), 0);
    previous = h;
  }
}

TEST(Colour, ClampsAndDegenerateRanges) {
  EXPECT_EQ(hue_colour(-10.0, 0.0, 1.0), (Rgb{0, 0, 255}));
  EXPECT_EQ(hue_colour(10.0, 0.0, 1.0), (Rgb{255, 0, 0}));
  EXPECT_EQ(hue_colour(3.0, 3.0, 3.0), (Rgb{0, 0, 255})) << "low == high: the low end";
  EXPECT_EQ(hue_colour(std::nan(""), 0.0, 1.0), (Rgb{0, 0, 255}));
}

TEST(Colour, ColourByScalarUsesFiniteRange) {
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> values = {0.5, -2.0, std::nan(""), 4.0, inf, 1.0};
  const std::vector<Rgb> c = colour_by_scalar(values);
  ASSERT_EQ(c.size(), values.size());
  EXPECT_EQ(c[1], (Rgb{0, 0, 255})) << "minimum";
  EXPECT_EQ(c[3], (Rgb{255, 0, 0})) << "maximum";
  EXPECT_EQ(c[0], hue_colour(0.5, -2.0, 4.0));
  EXPECT_EQ(c[5], hue_colour(1.0, -2.0, 4.0));
  EXPECT_EQ(c[2], (Rgb{0, 0, 255})) << "NaN";
  EXPECT_TRUE(colour_by_scalar(std::vector<double>{}).empty());
  const std::vector<double> constant(3, 7.0);
  for (const Rgb& x : colour_by_scalar(constant)) EXPECT_EQ(x, (Rgb{0, 0, 255}));
}

}  // namespace

// Clipping: the 1% of outliers at each end no longer decide the colour range.
TEST(Colour, ClippedRangeIgnoresOutliers) {
  std::vector<double> values(1000);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<double>(i % 100);
  values[0] = -1e6;
  values[1] = 1e6;
  const std::vector<Rgb> paper = colour_by_scalar(values);
  const std::vector<Rgb> clipped = colour_by_scalar(values, 0.01);
  // With min-max, 0 and 99 get nearly the same colour; clipped, they are the range's ends.
  EXPECT_EQ(paper[100], paper[199]);
  EXPECT_EQ(clipped[100], (Rgb{0, 0, 255}));
  EXPECT_EQ(clipped[199], hue_colour(1.0, 0.0, 1.0));
  EXPECT_EQ(clipped[1], hue_colour(1.0, 0.0, 1.0));  // clamped
}

}  // namespace pointfair
