// pointfair generate SHAPE OUT: test clouds of the paper's shapes, with noise.
#include <cmath>
#include <cstdio>

#include "commands.hpp"
#include "run_support.hpp"
#include "pointfair/shapes.hpp"

namespace pointfair::cli {

int run_generate(const Args& args) {
  std::string shape, output_path, clean_path;
  long long points = 20000;
  double noise_percent = 0.0;
  int seed = 1;
  OutputOptions output;
  output.colour_by = ColourBy::None;
  ArgumentParser parser("pointfair generate",
                        "Writes a sampled test shape: octahedron (vertices of the 4-1 subdivision "
                        "with the nearest point count), cube (area-uniform random samples of "
                        "[-1,1]^3), sphere (radius 1), cylinder (radius 1, height 2, side only). "
                        "Noise is Gaussian along the normal and both tangents, sigma in percent of "
                        "the bounding-box diagonal.");
  parser.positional("SHAPE", "octahedron | cube | sphere | cylinder", &shape);
  parser.positional("OUT", "Output point file (.ply, .xyz, ...), with normals nx ny nz.", &output_path);
  parser.value("points", "N", "Number of points (the octahedron picks the nearest subdivision). Default 20000.",
               [&](std::string_view v) { points = parse_int(v, "--points"); });
  parser.value("noise", "PERCENT", "Noise sigma in percent of the bounding-box diagonal. Default 0.",
               [&](std::string_view v) { noise_percent = parse_double(v, "--noise"); });
  parser.value("seed", "S", "Random seed. Default 1.", [&](std::string_view v) { seed = parse_int(v, "--seed"); });
  parser.value("clean", "FILE", "Also write the noise-free samples (same order) to FILE.",
               [&](std::string_view v) { clean_path = std::string(v); });
  parser.value("encoding", "binary|binary-be|ascii", "PLY encoding. Default binary.",
               [&](std::string_view v) { output.encoding = std::string(v); });
  if (!parser.parse(args)) return 0;
  if (points < 1 || points > 500'000'000) throw UsageError("--points must be in 1..500000000");
  if (!(noise_percent >= 0)) throw UsageError("--noise must be >= 0");

  const auto seed64 = static_cast<std::uint64_t>(seed);
  const auto count = static_cast<std::size_t>(points);
  SurfaceSamples samples;
  if (shape == "octahedron") {
    int level = 0;
    while (level < 10 && std::abs(std::pow(4.0, level + 2) + 2 - static_cast<double>(points)) <
                             std::abs(std::pow(4.0, level + 1) + 2 - static_cast<double>(points)))
      ++level;
    samples = mesh_vertices(subdivide_4_1(octahedron_mesh(), level));
  } else if (shape == "cube") {
    samples = sample_mesh(cube_mesh(), count, seed64);
  } else if (shape == "sphere") {
    samples = sample_sphere(count, 1.0, seed64);
  } else if (shape == "cylinder") {
    samples = sample_cylinder(count, 1.0, 2.0, seed64);
  } else {
    throw UsageError("pointfair generate: unknown shape '" + shape + "' (octahedron, cube, sphere, cylinder)");
  }
  auto to_table = [&](const std::vector<Vec3>& positions) {
    io::PointTable table;
    table.positions = positions;
    const char* names[3] = {"nx", "ny", "nz"};
    for (int c = 0; c < 3; ++c) {
      std::vector<double> v(positions.size());
      for (std::size_t i = 0; i < v.size(); ++i) v[i] = samples.normals[i][c];
      table.set(names[c], io::ScalarType::Float32, std::move(v));
    }
    return table;
  };
  if (!clean_path.empty()) write_output(clean_path, to_table(samples.points), output);
  std::vector<Vec3> noisy = samples.points;
  const double diagonal = bounding_box_diagonal(noisy);
  add_noise(noisy, noise_percent / 100.0 * diagonal, seed64 ^ 0x9e3779b97f4a7c15ULL);
  write_output(output_path, to_table(noisy), output);
  std::fprintf(stderr, "generate: %s, %zu points, noise sigma %.4g (%.3g%% of diagonal %.4g) -> %s\n",
               shape.c_str(), noisy.size(), noise_percent / 100.0 * diagonal, noise_percent, diagonal,
               output_path.c_str());
  return 0;
}

}  // namespace pointfair::cli
