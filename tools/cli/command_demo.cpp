// pointfair demo: the paper's octahedron experiment (Figure 4) on a built-in input.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "commands.hpp"
#include "interrupt.hpp"
#include "progress.hpp"
#include "run_support.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/render/png.hpp"
#include "pointfair/render/splats.hpp"
#include "pointfair/shapes/mesh_distance.hpp"
#include "pointfair/shapes/shapes.hpp"

namespace pointfair::cli {
namespace {

struct CloudScore {
  std::string name;
  double rms_all = 0, rms_edges = 0, rms_faces = 0;  // distance to the true surface / diagonal
  double seconds = 0, rate = 0;
  DisplacementStats moved;
};

// RMS distance to the true octahedron, over all points and split by whether the clean sample
// lies within `band` of a sharp edge.
// The subdivision is flat on each face, so the octahedron's eight triangles are the truth.
CloudScore score(std::string name, std::span<const Vec3> cloud, std::span<const Vec3> clean,
                 double band, double diagonal) {
  const TriangleMesh base = octahedron_mesh();
  double all = 0, edges = 0, faces = 0;
  std::size_t n_edges = 0, n_faces = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double d = distance_to_mesh(cloud[i], base);
    double to_edge = std::numeric_limits<double>::infinity();
    for (const auto& t : base.triangles)
      for (int e = 0; e < 3; ++e)
        to_edge = std::min(to_edge, distance_to_segment(clean[i], base.vertices[t[e]], base.vertices[t[(e + 1) % 3]]));
    all += d * d;
    if (to_edge < band) {
      edges += d * d;
      ++n_edges;
    } else {
      faces += d * d;
      ++n_faces;
    }
  }
  CloudScore s;
  s.name = std::move(name);
  s.rms_all = std::sqrt(all / static_cast<double>(std::max<std::size_t>(1, cloud.size()))) / diagonal;
  s.rms_edges = std::sqrt(edges / static_cast<double>(std::max<std::size_t>(1, n_edges))) / diagonal;
  s.rms_faces = std::sqrt(faces / static_cast<double>(std::max<std::size_t>(1, n_faces))) / diagonal;
  return s;
}

io::PointTable coloured_table(std::span<const Vec3> positions, const PointAttributes& attributes,
                              const OutputOptions& output) {
  io::PointTable table;
  table.positions.assign(positions.begin(), positions.end());
  table.position_type = io::ScalarType::Float32;
  add_result_columns(table, attributes, output, false);
  return table;
}

// One cloud of the picture: its points, normals and maximal |principal curvature|.
struct PictureCloud {
  std::vector<Vec3> points;
  std::vector<Vec3> normals;
  std::vector<double> kmax;
};

PictureCloud picture_cloud(std::span<const Vec3> positions, PointAttributes attributes) {
  PictureCloud c;
  c.points.assign(positions.begin(), positions.end());
  c.kmax.resize(positions.size());
  for (std::size_t i = 0; i < c.kmax.size(); ++i)
    c.kmax[i] = std::max(std::abs(attributes.k1[i]), std::abs(attributes.k2[i]));
  c.normals = std::move(attributes.normal);
  return c;
}

// Value at the quantile q of all clouds' finite kmax.
double kmax_quantile(std::span<const PictureCloud> clouds, double q) {
  std::vector<double> all;
  for (const auto& c : clouds)
    for (const double v : c.kmax)
      if (std::isfinite(v)) all.push_back(v);
  if (all.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(all.size() - 1));
  std::nth_element(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(k), all.end());
  return all[k];
}

}  // namespace

int run_demo(const Args& args) {
  std::string out_dir = "out";
  int level = 6;
  double noise_percent = 1.5;
  int seed = 1;
  SmoothParams params;
  OutputOptions output;
  output.colour_by = ColourBy::MaxCurvature;  // the demo's pictures are coloured
  ArgumentParser parser(
      "pointfair demo",
      "The paper's octahedron experiment (Figure 4) on a built-in input: a regular 4-1 "
      "subdivision of the octahedron (level 6: 16,386 points on 32,768 triangles), Gaussian "
      "noise along the normal and both tangents with sigma = 1.5% of the bounding-box diagonal, "
      "then the anisotropic flow (which may stop early: see --stop-lambda-ratio) and, for "
      "comparison, the isotropic flow for all --steps. "
      "Writes PLY files coloured by maximal principal curvature and summary.json into the "
      "output folder, and prints a summary.");
  parser.value("out", "DIR", "Output folder (created if missing). Default ./out.",
               [&](std::string_view v) { out_dir = std::string(v); });
  parser.value("level", "L", "4-1 subdivision levels of the octahedron (points = 4^(L+1) + 2). Default 6.",
               [&](std::string_view v) { level = parse_int(v, "--level"); });
  parser.value("noise", "PERCENT", "Noise sigma in percent of the bounding-box diagonal. Default 1.5.",
               [&](std::string_view v) { noise_percent = parse_double(v, "--noise"); });
  parser.value("seed", "S", "Random seed of the noise. Default 1.",
               [&](std::string_view v) { seed = parse_int(v, "--seed"); });
  add_method_options(parser, params);
  add_output_options(parser, output, false);
  parser.example("pointfair demo");
  parser.example("pointfair demo --out octahedron --noise 2 --level 5");
  if (!parser.parse(args)) return 0;
  if (level < 1 || level > 9) throw UsageError("--level must be in 1..9");
  if (!(noise_percent >= 0)) throw UsageError("--noise must be >= 0");
  params.validate();
  set_thread_count(output.threads);

  const TriangleMesh truth = subdivide_4_1(octahedron_mesh(), level);
  const std::vector<Vec3> clean = mesh_vertices(truth).points;
  const double diagonal = bounding_box_diagonal(clean);
  std::vector<Vec3> noisy = clean;
  add_noise(noisy, noise_percent / 100.0 * diagonal, static_cast<std::uint64_t>(seed));
  const double band = 0.01 * diagonal;

  std::filesystem::create_directories(out_dir);
  const std::filesystem::path dir(out_dir);
  std::vector<CloudScore> scores;
  std::vector<PictureCloud> pictured;  // noisy, anisotropic, isotropic
  scores.push_back(score("noisy input", noisy, clean, band, diagonal));
  {
    const Neighborhoods nb = build_neighborhoods(noisy, resolve_k(params, noisy).neighbors);
    const double lambda = resolve_lambda(noisy, nb, params.flow);
    PointAttributes a = compute_attributes(noisy, nb, params.flow, lambda);
    write_output(dir / "octahedron_noisy.ply", coloured_table(noisy, a, output), output);
    pictured.push_back(picture_cloud(noisy, std::move(a)));
  }

  JsonObject runs;
  for (const Flow flow : {Flow::Anisotropic, Flow::Isotropic}) {
    SmoothParams run = params;
    run.flow.flow = flow;
    std::vector<Vec3> positions = noisy;
    Progress progress("demo: " + to_string(flow) + " step", !output.quiet);
    SmoothOptions options;
    // Files written before the signal are complete; summary.json is written last.
    options.progress = [&](SmoothStage stage, std::size_t done, std::size_t total) {
      throw_if_interrupted("summary.json not written");
      if (stage == SmoothStage::Steps) progress.update(static_cast<long long>(done), static_cast<long long>(total));
    };
    const auto t0 = std::chrono::steady_clock::now();
    const SmoothReport report = smooth(positions, run, options);
    throw_if_interrupted("summary.json not written");
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    progress.finish();
    const std::string file = "octahedron_" + to_string(flow) + ".ply";
    PointAttributes a = compute_attributes(positions, report.neighborhoods, run.flow, report.lambda);
    write_output(dir / file, coloured_table(positions, a, output), output);
    pictured.push_back(picture_cloud(positions, std::move(a)));
    CloudScore s = score(to_string(flow) + "tropic, " + std::to_string(report.steps) + " steps",
                         positions, clean, band, diagonal);
    s.seconds = seconds;
    s.rate = report.seconds_steps > 0 ? static_cast<double>(positions.size()) * report.steps / report.seconds_steps : 0;
    s.moved = displacement_stats(noisy, positions);
    scores.push_back(s);
    JsonObject r;
    r.add("file", (dir / file).string()).add("parameters", parameters_json(run, report.k, report.eps, report.lambda));
    r.add("seconds", seconds).add("point_steps_per_second", s.rate);
    r.add("rms_distance_over_diagonal", s.rms_all).add("rms_near_edges_over_diagonal", s.rms_edges)
        .add("rms_on_faces_over_diagonal", s.rms_faces);
    r.add("displacement", to_json(s.moved)).add("degenerate_points", report.degenerate);
    runs.add(to_string(flow), r);
  }

  throw_if_interrupted("summary.json not written");
  JsonObject input;
  input.add("shape", "octahedron, 4-1 subdivision").add("level", level).add("points", clean.size())
      .add("noise_percent_of_diagonal", noise_percent).add("seed", seed).add("bbox_diagonal", diagonal)
      .add("rms_distance_over_diagonal", scores[0].rms_all).add("rms_near_edges_over_diagonal", scores[0].rms_edges)
      .add("rms_on_faces_over_diagonal", scores[0].rms_faces).add("edge_band_over_diagonal", 0.01);
  JsonObject summary;
  summary.add("command", "demo").add("version", version()).add("threads", thread_count())
      .add("input", input).add("runs", runs);
  // The paper's Figure 4 as one picture: noisy input, anisotropic and isotropic result, with
  // one colour range (1st to 99th percentile of all three) so that the panels compare.
  {
    const double low = kmax_quantile(pictured, 0.01), high = kmax_quantile(pictured, 0.99);
    std::vector<std::vector<Rgb>> colours(pictured.size());
    std::vector<render::CloudView> views;
    for (std::size_t i = 0; i < pictured.size(); ++i) {
      for (const double v : pictured[i].kmax) colours[i].push_back(hue_colour(v, low, high));
      views.push_back({pictured[i].points, colours[i], pictured[i].normals});
    }
    const std::vector<std::string> labels = {"noisy input", "anisotropic", "isotropic"};
    render::RenderParams picture;
    picture.width = 480;
    picture.height = 480;
    const render::ColourLegend legend{"max abs principal curvature (1/length)", low, high};
    render::write_png(dir / "octahedron.png", render::render_panels(views, labels, picture, legend));
  }
  io::write_file_atomically(dir / "summary.json",
                            [&](io::FileSink& sink) { sink.write(summary.str() + "\n"); });

  std::printf("pointfair demo: octahedron, %zu points, noise %.2g%% of the diagonal, %d steps, %d threads\n",
              clean.size(), noise_percent, params.steps, thread_count());
  std::printf("RMS distance to the true surface, in 1e-3 of the bounding-box diagonal\n");
  std::printf("(near edges: clean sample within 1%% of the diagonal from a sharp edge)\n\n");
  std::printf("  %-26s %8s %11s %9s %9s %14s %12s\n", "cloud", "all", "near edges", "faces", "time s",
              "pt-steps/s", "max moved");
  for (const auto& s : scores)
    std::printf("  %-26s %8.3f %11.3f %9.3f %9.2f %14.3g %12.4g\n", s.name.c_str(), 1e3 * s.rms_all,
                1e3 * s.rms_edges, 1e3 * s.rms_faces, s.seconds, s.rate, s.moved.max);
  std::printf("\nwrote %s/octahedron_{noisy,aniso,iso}.ply (coloured by maximal principal curvature,\n"
              "      blue low to red high), %s/octahedron.png (the three side by side, one colour\n"
              "      range) and %s/summary.json\n",
              out_dir.c_str(), out_dir.c_str(), out_dir.c_str());
  if (output.json) std::cout << summary.str() << std::endl;
  return 0;
}

}  // namespace pointfair::cli
