// pointfair render IN OUT.png: a headless picture of one cloud or of side-by-side panels.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

#include "commands.hpp"
#include "run_support.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/render/splats.hpp"

namespace pointfair::cli {

namespace {

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) if (!item.empty()) items.push_back(item);
  return items;
}

// Value at the given quantile of the finite values (0 if none).
double quantile(std::vector<double> values, double q) {
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); }), values.end());
  if (values.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

int run_render(const Args& args) {
  std::string input, output_path, panels, labels_text, colour = "kmax", view = "iso", range_text;
  render::RenderParams params;
  SmoothParams method;
  int threads = 0;
  ArgumentParser parser(
      "pointfair render",
      "Draws point clouds into a PNG without a display: orthographic camera, the points framed "
      "to fill the panel, z-buffered splats sized by each point's own spacing and lying in its "
      "tangent plane, Lambert shading from the unsigned normal, colour by maximal |principal "
      "curvature| or by |A| (blue low to red high, as CloudCompare, with a legend of the range "
      "and its unit), by the file's red/green/blue, or one yellow. Several inputs become "
      "side-by-side panels with one camera, one framing and one colour range.");
  parser.positional("IN", "Point file, or several separated by commas (panels).", &input);
  parser.positional("OUT", "PNG file to write.", &output_path);
  parser.value("panels", "A,B,...", "More point files, drawn as panels after IN.",
               [&](std::string_view v) { panels = std::string(v); });
  parser.value("labels", "A,B,...", "Panel labels, in order.", [&](std::string_view v) { labels_text = std::string(v); });
  parser.value("colour", "kmax|laplacian|file|none",
               "Colour source. Default kmax (the method's curvature with the method options below).",
               [&](std::string_view v) { colour = std::string(v); });
  parser.value("range", "LOW,HIGH", "Scalar range of the colour map (blue at LOW, red at HIGH). Default: 1st to 99th "
               "percentile over all panels.",
               [&](std::string_view v) { range_text = std::string(v); });
  parser.value("view", "iso|front|side|top|back", "Camera preset. Default iso.", [&](std::string_view v) { view = std::string(v); });
  parser.value("yaw", "DEGREES", "Turn the camera about the screen's vertical axis. Default 0.",
               [&](std::string_view v) { params.yaw_degrees = parse_double(v, "--yaw"); });
  parser.value("size", "PIXELS", "Width and height of each panel. Default 640.", [&](std::string_view v) {
    params.width = params.height = parse_int(v, "--size");
  });
  parser.value("splat", "F",
               "Splat radius, times each point's distance to its 8th neighbour in its tangent plane. "
               "Default 0.7 (closes a dense surface).",
               [&](std::string_view v) { params.splat_scale = parse_double(v, "--splat"); });
  parser.flag("flat", "No shading.", [&] { params.shade = false; });
  parser.value("threads", "N", "Worker threads (0 = all cores). Default 0.",
               [&](std::string_view v) { threads = parse_int(v, "--threads"); });
  add_method_options(parser, method);
  parser.example("pointfair render noisy.ply,smoothed.ply compare.png --labels noisy,smoothed");
  parser.example("pointfair render smoothed.ply top.png --view top --colour kmax");
  if (!parser.parse(args)) return 0;
  params.view = render::parse_view(view);
  params.validate();
  method.validate();
  if (colour != "kmax" && colour != "laplacian" && colour != "file" && colour != "none")
    throw UsageError("--colour must be kmax, laplacian, file or none");
  set_thread_count(threads);

  std::vector<std::string> files = split_list(input);
  for (const auto& f : split_list(panels)) files.push_back(f);
  if (files.empty()) throw UsageError("pointfair render: no input file");
  const std::vector<std::string> labels = split_list(labels_text);

  std::vector<io::PointTable> tables;
  std::vector<std::vector<double>> scalars;
  std::vector<std::vector<Vec3>> normals;  // the method's, when it ran; else render estimates them
  for (const auto& f : files) {
    tables.push_back(read_input(f, true));
    std::vector<double> s;
    std::vector<Vec3> n;
    if ((colour == "kmax" || colour == "laplacian") && tables.back().size() > 3) {
      const auto& points = tables.back().positions;
      const Neighborhoods nb = build_neighborhoods(points, resolve_k(method, points).neighbors);
      const double lambda = resolve_lambda(points, nb, method.flow);
      PointAttributes a = compute_attributes(points, nb, method.flow, lambda);
      s.resize(points.size());
      for (std::size_t i = 0; i < s.size(); ++i)
        s[i] = colour == "laplacian" ? a.laplacian_norm[i] : std::max(std::abs(a.k1[i]), std::abs(a.k2[i]));
      n = std::move(a.normal);
    }
    scalars.push_back(std::move(s));
    normals.push_back(std::move(n));
  }
  double low = 0, high = 0;
  if (!range_text.empty()) {
    const auto parts = split_list(range_text);
    if (parts.size() != 2) throw UsageError("--range needs LOW,HIGH");
    low = parse_double(parts[0], "--range");
    high = parse_double(parts[1], "--range");
  } else {
    std::vector<double> all;
    for (const auto& s : scalars) all.insert(all.end(), s.begin(), s.end());
    low = quantile(all, 0.01);
    high = quantile(all, 0.99);
  }
  std::vector<std::vector<Rgb>> colours(tables.size());
  for (std::size_t k = 0; k < tables.size(); ++k) {
    if (!scalars[k].empty()) {
      for (const double v : scalars[k]) colours[k].push_back(hue_colour(v, low, high));
    } else if (colour == "file") {
      const auto* r = tables[k].find("red");
      const auto* g = tables[k].find("green");
      const auto* b = tables[k].find("blue");
      if (r && g && b)
        for (std::size_t i = 0; i < tables[k].size(); ++i)
          colours[k].push_back({static_cast<std::uint8_t>(std::clamp(r->values[i], 0.0, 255.0)),
                                static_cast<std::uint8_t>(std::clamp(g->values[i], 0.0, 255.0)),
                                static_cast<std::uint8_t>(std::clamp(b->values[i], 0.0, 255.0))});
    }
  }
  std::vector<render::CloudView> views;
  for (std::size_t k = 0; k < tables.size(); ++k) views.push_back({tables[k].positions, colours[k], normals[k]});
  std::optional<render::ColourLegend> legend;
  if (colour == "kmax" || colour == "laplacian")
    legend = render::ColourLegend{colour == "kmax" ? "max abs principal curvature (1/length)"
                                                   : "mean curvature vector length (1/length)",
                                  low, high};
  const render::Image image = render::render_panels(views, labels, params, legend);
  render::write_png(output_path, image);
  std::fprintf(stderr, "render: %zu panel%s, %dx%d -> %s\n", views.size(), views.size() == 1 ? "" : "s", image.width,
               image.height, output_path.c_str());
  return 0;
}

}  // namespace pointfair::cli
