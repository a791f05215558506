#pragma once
// The thin-sheet case of the quality benchmark: a closed box-shaped plate whose two large
// faces lie a few noise sigmas apart, so that each point's neighbourhood reaches the other
// side.
#include <filesystem>

namespace pointfair::quality {

/// Thickness (length) of a `length` x `width` plate whose two sides are `sigmas` noise sigmas
/// apart when the noise sigma is `noise_percent` % of the bounding-box diagonal of the plate
/// itself (the benchmark's noise convention): solves t = s p sqrt(l^2 + w^2 + t^2), with
/// s p = sigmas x noise_percent / 100 < 1.
double thin_plate_thickness(double length, double width, double sigmas, double noise_percent);

/// Writes the plate [-l/2, l/2] x [-w/2, w/2] x [-t/2, t/2] as an OFF file of 12 triangles
/// (outward, counter-clockwise).
void write_thin_plate_off(const std::filesystem::path& file, double length, double width, double thickness);

}  // namespace pointfair::quality
