#pragma once
// Colouring by a scalar: blue low, red high, as CloudCompare's default scale ("Blue > Green >
// Yellow > Red"), so that our files and pictures read the same as theirs. The hue runs linearly
// over the colour circle from 240 degrees (blue, the minimum) through cyan, green and yellow to
// 0 (red, the maximum), at full saturation and value.
//
// Differs from the paper: Lange & Polthier (2005), Section 5, run the hue the other way, from 0
// (red, the minimum) to 1.5 pi (the maximum); there red means low. One convention everywhere
// (PLY colours, `render`, the demo's picture) is worth more than the paper's.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace pointfair {

using Rgb = std::array<std::uint8_t, 3>;

/// Colour of `value` in [low, high] (clamped): blue at low, red at high. low == high and NaN map
/// to blue (the low end).
Rgb hue_colour(double value, double low, double high);

/// Colours of all values. low and high are the `clip` and 1 - `clip` quantiles of the finite
/// values: clip = 0 is the minimum and maximum (as in the paper); a small clip (e.g. 0.01)
/// keeps a few outliers from squeezing every other point into one colour.
std::vector<Rgb> colour_by_scalar(std::span<const double> values, double clip = 0.0);

}  // namespace pointfair
