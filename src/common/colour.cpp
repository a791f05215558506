#include "pointfair/common/colour.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace pointfair {

Rgb hue_colour(double value, double low, double high) {
  double t = high > low ? (value - low) / (high - low) : 0.0;
  if (!std::isfinite(t)) t = 0.0;
  t = std::clamp(t, 0.0, 1.0);
  // Hue angle 0..1.5 pi, i.e. 0..270 degrees: red, yellow, green, cyan, blue, violet-blue.
  const double h = t * 1.5 * std::numbers::pi / (std::numbers::pi / 3.0);  // in sextants, 0..4.5
  const int sextant = std::min(5, static_cast<int>(h));
  const double f = h - sextant;
  const double rise = f, fall = 1.0 - f;
  double r = 0, g = 0, b = 0;
  switch (sextant) {
    case 0: r = 1; g = rise; b = 0; break;
    case 1: r = fall; g = 1; b = 0; break;
    case 2: r = 0; g = 1; b = rise; break;
    case 3: r = 0; g = fall; b = 1; break;
    case 4: r = rise; g = 0; b = 1; break;
    default: r = 1; g = 0; b = fall; break;
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
