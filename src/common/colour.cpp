#include "pointfair/common/colour.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pointfair {

Rgb hue_colour(double value, double low, double high) {
  double t = high > low ? (value - low) / (high - low) : 0.0;
  if (!std::isfinite(t)) t = 0.0;
  t = std::clamp(t, 0.0, 1.0);
  // Hue 240 degrees (blue) at t = 0 down to 0 (red) at t = 1, in sextants of 60 degrees:
  // blue, cyan, green, yellow, red.
  const double h = 4.0 * (1.0 - t);  // 0..4
  const int sextant = std::min(3, static_cast<int>(h));
  const double f = h - sextant;
  double r = 0, g = 0, b = 0;
  switch (sextant) {
    case 0: r = 1; g = f; b = 0; break;        // red to yellow
    case 1: r = 1 - f; g = 1; b = 0; break;    // yellow to green
    case 2: r = 0; g = 1; b = f; break;        // green to cyan
    default: r = 0; g = 1 - f; b = 1; break;   // cyan to blue
  }
  auto byte = [](double c) { return static_cast<std::uint8_t>(std::lround(c * 255.0)); };
  return {byte(r), byte(g), byte(b)};
}

std::vector<Rgb> colour_by_scalar(std::span<const double> values, double clip) {
  std::vector<double> finite;
  finite.reserve(values.size());
  for (const double v : values)
    if (std::isfinite(v)) finite.push_back(v);
  double low = 0.0, high = 0.0;
  if (!finite.empty()) {
    clip = std::clamp(clip, 0.0, 0.5);
    const auto last = static_cast<double>(finite.size() - 1);
    const auto at = [&](double q) {
      auto it = finite.begin() + static_cast<std::ptrdiff_t>(std::lround(q * last));
      std::nth_element(finite.begin(), it, finite.end());
      return *it;
    };
    low = at(clip);
    high = at(1.0 - clip);
  }
  std::vector<Rgb> colours(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) colours[i] = hue_colour(values[i], low, high);
  return colours;
}

}  // namespace pointfair
