#include "pointfair/render/legend.hpp"

#include <algorithm>
#include <cstdio>

#include "pointfair/common/colour.hpp"

namespace pointfair::render {

namespace {

constexpr int kScale = 2;            // font scale: 10 x 14 pixel capitals
constexpr int kText = 7 * kScale;    // text height
constexpr int kBar = 16;             // bar height
constexpr int kPad = 8;              // outer padding and gaps
constexpr Rgb kInk = {20, 20, 20};

}  // namespace

int legend_height() { return kPad + kText + kPad / 2 + kBar + kPad; }

std::string legend_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", value);
  return text;
}

void draw_legend(Image& image, int x, int y, int width, const ColourLegend& legend) {
  // The title at the font's double size, or at its own size (vertically centred in the same
  // rows) when that does not fit.
  const int title_scale = text_width(legend.title, kScale) <= width - 2 * kPad ? kScale : 1;
  const int title_width = text_width(legend.title, title_scale);
  const int title_y = y + kPad + (kText - 7 * title_scale) / 2;
  draw_text(image, x + std::max(0, (width - title_width) / 2), title_y, legend.title, kInk, title_scale);

  const std::string low = legend_number(legend.low), high = legend_number(legend.high);
  const int bar_y = y + kPad + kText + kPad / 2;
  const int text_y = bar_y + (kBar - kText) / 2;
  // The bar between the two numbers, at least a quarter of the width.
  const int low_width = text_width(low, kScale), high_width = text_width(high, kScale);
  int bar_x0 = x + kPad + low_width + kPad;
  int bar_x1 = x + width - kPad - high_width - kPad;  // one past the bar's last column
  if (bar_x1 - bar_x0 < width / 4) {
    bar_x0 = x + (width - width / 4) / 2;
    bar_x1 = bar_x0 + width / 4;
  }
  draw_text(image, bar_x0 - kPad - low_width, text_y, low, kInk, kScale);
  draw_text(image, bar_x1 + kPad, text_y, high, kInk, kScale);
  const int columns = std::max(1, bar_x1 - bar_x0);
  for (int c = 0; c < columns; ++c) {
    // Column c shows the colour of its centre's value, so the ends are the map's ends.
    const double t = columns == 1 ? 0.0 : static_cast<double>(c) / (columns - 1);
    const Rgb colour = hue_colour(t, 0.0, 1.0);
    for (int r = 0; r < kBar; ++r) image.set(bar_x0 + c, bar_y + r, colour);
  }
}

}  // namespace pointfair::render
