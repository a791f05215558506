#pragma once
// Colouring by a scalar, Lange & Polthier (2005), Section 5: the hue runs linearly over the
// colour circle from 0 (the minimum) to 1.5 pi (the maximum), at full saturation and value.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace pointfair {

using Rgb = std::array<std::uint8_t, 3>;

/// Colour of `value` in [low, high] (clamped). low == high maps everything to hue 0.
Rgb hue_colour(double value, double low, double high);

/// Colours of all values. low and high are the `clip` and 1 - `clip` quantiles of the finite
/// values: clip = 0 is the paper's minimum and maximum; a small clip (e.g. 0.01) keeps a few
/// outliers from squeezing every other point into one colour.
std::vector<Rgb> colour_by_scalar(std::span<const double> values, double clip = 0.0);

}  // namespace pointfair
