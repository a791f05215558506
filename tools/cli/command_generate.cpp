// pointfair generate SHAPE OUT: test clouds of the paper's shapes (and of any triangle mesh),
// with the paper's "normal and tangential" noise, plus the ground truth `pointfair eval` needs.
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "commands.hpp"
#include "pointfair/common/params_error.hpp"
#include "las_options.hpp"
#include "run_support.hpp"
#include "pointfair/eval/truth.hpp"
#include "pointfair/shapes/shapes.hpp"

namespace pointfair::cli {

int run_generate(const Args& args) {
  std::string shape, output_path, clean_path, truth_path, mesh_path;
  long long points = 20000;
  double noise_percent = 0.0;
  int seed = 1;
  eval::TruthSpec spec;
  OutputOptions output;
  output.colour_by = ColourBy::None;
  ArgumentParser parser(
      "pointfair generate",
      "Writes a sampled test shape of Lange & Polthier (2005), Section 5: octahedron (vertices of "
      "the regular 4-1 subdivision with the nearest point count), cube ([-1,1]^3), "
      "truncated-octahedron (permutations of (0,±1,±2)), sphere (radius 1), cylinder (radius 1, "
      "height 2, side only), torus (radii 1 and 0.4), cylinder-plane (Figure 2: the union of the "
      "cylinder y^2+z^2=1, |x|<=2 and the plane z=0, |x|,|y|<=2), enneper (Enneper's minimal "
      "surface over the parameter disc of radius 1.2, in place of the paper's Costa surface), or "
      "mesh (--mesh FILE, an OFF or PLY triangle mesh). Every shape except the octahedron is an "
      "area-uniform random sample. Noise is Gaussian with the same sigma along the normal and "
      "both tangents (an isotropic 3-D Gaussian), sigma in percent of the bounding-box diagonal "
      "of the clean samples.");
  parser.positional("SHAPE",
                    "octahedron | cube | truncated-octahedron | sphere | cylinder | torus | "
                    "cylinder-plane | enneper | mesh",
                    &shape);
  parser.positional("OUT", "Output point file (.ply, .xyz, ...), with the true normals nx ny nz.", &output_path);
  parser.value("points", "N", "Number of points (the octahedron picks the nearest subdivision). Default 20000.",
               [&](std::string_view v) { points = parse_int(v, "--points"); });
  parser.value("noise", "PERCENT", "Noise sigma in percent of the bounding-box diagonal. Default 0.",
               [&](std::string_view v) { noise_percent = parse_double(v, "--noise"); });
  parser.value("seed", "S", "Random seed. Default 1.", [&](std::string_view v) { seed = parse_int(v, "--seed"); });
  parser.value("mesh", "FILE", "Triangle mesh (.off or .ply) to sample for SHAPE mesh.",
               [&](std::string_view v) { mesh_path = std::string(v); });
  parser.value("clean", "FILE", "Also write the noise-free samples (same order) to FILE.",
               [&](std::string_view v) { clean_path = std::string(v); });
  parser.value("truth-out", "FILE",
               "Also write the ground truth for 'pointfair eval --truth FILE': a small text file "
               "naming the shape and its parameters (and the mesh file, as an absolute path).",
               [&](std::string_view v) { truth_path = std::string(v); });
  parser.value("radius", "R", "Sphere, cylinder and cylinder-plane radius. Default 1.",
               [&](std::string_view v) { spec.radius = parse_double(v, "--radius"); });
  parser.value("major", "R", "Torus major radius. Default 1.",
               [&](std::string_view v) { spec.major = parse_double(v, "--major"); });
  parser.value("minor", "R", "Torus tube radius. Default 0.4.",
               [&](std::string_view v) { spec.minor = parse_double(v, "--minor"); });
  parser.value("encoding", "binary|binary-be|ascii", "PLY encoding. Default binary.",
               [&](std::string_view v) { output.encoding = std::string(v); });
  add_las_options(parser, output.las);
  parser.example("pointfair generate cube noisy.ply --points 20000 --noise 0.5 --clean clean.ply --truth-out cube.truth");
  parser.example("pointfair generate mesh noisy.ply --mesh part.off --noise 1");
  if (!parser.parse(args)) return 0;
  require_las_output(output.las, output_path);
  if (points < 1 || points > 500'000'000) throw UsageError("--points must be in 1..500000000");
  if (!(noise_percent >= 0) || !std::isfinite(noise_percent)) throw UsageError("--noise must be >= 0");

  static const char* const kShapes[] = {"octahedron", "cube", "truncated-octahedron", "sphere", "cylinder",
                                        "torus", "cylinder-plane", "enneper", "mesh"};
  bool known = false;
  for (const char* s : kShapes) known = known || shape == s;
  if (!known)
    throw UsageError("pointfair generate: unknown shape '" + shape +
                     "' (octahedron, cube, truncated-octahedron, sphere, cylinder, torus, cylinder-plane, enneper, mesh)");
  spec.shape = shape;
  if (shape == "cylinder") spec.length = 2.0;
  if (shape == "mesh") {
    if (mesh_path.empty()) throw UsageError("pointfair generate mesh: --mesh FILE is required");
    spec.mesh = std::filesystem::absolute(mesh_path);
  } else if (!mesh_path.empty()) {
    throw UsageError("--mesh is only for SHAPE mesh");
  }

  const auto seed64 = static_cast<std::uint64_t>(seed);
  // A mesh that cannot be sampled (no triangles, zero area) is a problem of its file: named.
  const SurfaceSamples samples = [&] {
    try {
      return eval::generate_clean_samples(spec, static_cast<std::size_t>(points), seed64);
    } catch (const ParamError& e) {
      if (shape != "mesh") throw;
      throw io::IoError(mesh_path + ": " + e.what());
    }
  }();
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
  if (!truth_path.empty()) eval::write_truth_file(truth_path, spec);
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
