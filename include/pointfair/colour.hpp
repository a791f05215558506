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

/// Colours of all values, with low and high the minimum and maximum of the finite values.
std::vector<Rgb> colour_by_scalar(std::span<const double> values);

}  // namespace pointfair
