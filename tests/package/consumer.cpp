// Uses the installed package: a noisy sphere smoothed in core (through a PLY file, as the
// README's example) and out of core (imported into a container); exits 0 when both runs
// bring the points closer to the sphere.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <span>

#include "pointfair/io/point_file.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/tiles/import.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"

namespace {

double rms_off_unit_sphere(std::span<const pointfair::Vec3> points) {
  double sum = 0.0;
  for (const pointfair::Vec3& p : points) sum += (p.norm() - 1.0) * (p.norm() - 1.0);
  return std::sqrt(sum / static_cast<double>(points.size()));
}

}  // namespace

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  if (argc != 2) {
    std::fprintf(stderr, "usage: consumer FOLDER\n");
    return 2;
  }
  const fs::path folder = argv[1];
  pointfair::io::PointTable noisy;
  noisy.positions = pointfair::sample_sphere(5000, 1.0, 7).points;
  pointfair::add_noise(noisy.positions, 0.01, 8);
  pointfair::io::write_points(folder / "noisy.ply", noisy);

  // In core: read, smooth with the defaults, write.
  pointfair::io::PointTable cloud = pointfair::io::read_points(folder / "noisy.ply");
  const pointfair::SmoothReport report = pointfair::smooth(cloud.positions, pointfair::SmoothParams{});
  pointfair::io::write_points(folder / "smooth.ply", cloud);
  const double before = rms_off_unit_sphere(noisy.positions);
  const double after = rms_off_unit_sphere(pointfair::io::read_points(folder / "smooth.ply").positions);
  std::printf("in core: %d steps, k %d, RMS off the sphere %.5f -> %.5f\n", report.steps, report.k, before, after);

  // Out of core: the same cloud through a container.
  pointfair::tiles::import_points(folder / "noisy.ply", folder / "scan.h5");
  const pointfair::tiles::OutOfCoreReport tiled =
      pointfair::tiles::smooth_out_of_core(folder / "scan.h5", folder / "smooth.h5", pointfair::SmoothParams{});
  std::printf("out of core: %d steps\n", tiled.steps);
  return after < 0.5 * before && tiled.steps == report.steps ? 0 : 1;
}
