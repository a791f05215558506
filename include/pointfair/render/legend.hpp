#pragma once
// The colour legend of a picture coloured by a scalar: a bar running through the colour map
// (pointfair/common/colour.hpp: blue at the low end, red at the high end) with the low and the
// high value written at its ends and a title naming the quantity and its unit above it.
#include <string>

#include "pointfair/render/png.hpp"

namespace pointfair::render {

struct ColourLegend {
  /// The quantity and its unit, e.g. "max |k|, 1/unit". ASCII; drawn in capitals.
  std::string title;
  /// The values at the bar's ends: the range the colours were mapped from.
  double low = 0.0;
  double high = 0.0;
};

/// Height in pixels of the strip draw_legend fills.
int legend_height();

/// Draws the legend into the strip of `image` from (x, y), `width` pixels wide and
/// legend_height() tall: the title centred on top, then "low [bar] high". The bar keeps at
/// least a quarter of the width; numbers are printed with 3 significant digits.
void draw_legend(Image& image, int x, int y, int width, const ColourLegend& legend);

/// How `value` is written on a legend: 3 significant digits, "%.3g" ("0.0123", "1.5e+03").
std::string legend_number(double value);

}  // namespace pointfair::render
