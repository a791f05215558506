#include "thin_plate.hpp"

#include <array>
#include <cmath>
#include <fstream>
#include <stdexcept>

namespace pointfair::quality {

double thin_plate_thickness(double length, double width, double sigmas, double noise_percent) {
  const double sp = sigmas * noise_percent / 100.0;
  if (!(sp > 0.0 && sp < 1.0)) throw std::invalid_argument("thin plate: sigmas x noise must be in (0, 100%)");
  return sp * std::sqrt((length * length + width * width) / (1.0 - sp * sp));
}

void write_thin_plate_off(const std::filesystem::path& file, double length, double width, double thickness) {
  std::ofstream off(file);
  off.precision(17);
  off << "OFF\n8 12 0\n";
  // Vertex v = 4 * (z > 0) + 2 * (y > 0) + (x > 0).
  for (int v = 0; v < 8; ++v)
    off << ((v & 1) ? 0.5 : -0.5) * length << ' ' << ((v & 2) ? 0.5 : -0.5) * width << ' '
        << ((v & 4) ? 0.5 : -0.5) * thickness << '\n';
  // Each face as a quad (counter-clockwise seen from outside), split into two triangles.
  const std::array<std::array<int, 4>, 6> quads{{{0, 2, 3, 1},    // z-
                                                 {4, 5, 7, 6},    // z+
                                                 {0, 1, 5, 4},    // y-
                                                 {2, 6, 7, 3},    // y+
                                                 {0, 4, 6, 2},    // x-
                                                 {1, 3, 7, 5}}};  // x+
  for (const auto& q : quads) {
    off << "3 " << q[0] << ' ' << q[1] << ' ' << q[2] << '\n';
    off << "3 " << q[0] << ' ' << q[2] << ' ' << q[3] << '\n';
  }
  if (!off) throw std::runtime_error(file.string() + ": could not write the thin plate");
}

}  // namespace pointfair::quality
