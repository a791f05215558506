// pointfair info FILE|DIR: what a point file holds and what the defaults would do with it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "arguments.hpp"
#include "commands.hpp"
#include "crs_text.hpp"
#include "interrupt.hpp"
#include "json_writer.hpp"
#include "number_text.hpp"
#include "out_of_core.hpp"
#include "run_support.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/file_lock.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/neighbors/neighborhood_size.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair::cli {
namespace {

// Whether the defaults run a coarse level on a cloud with this noise ratio.
bool coarse_level_runs(double noise_ratio) {
  const SmoothParams defaults;
  return defaults.coarse && noise_ratio >= defaults.coarse->min_noise_ratio;
}

namespace fs = std::filesystem;

// 1234567 as "1,234,567".
std::string count_text(std::uint64_t n) {
  std::string digits = std::to_string(n), out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

struct Range {
  double min = std::numeric_limits<double>::infinity();
  double max = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (std::isnan(v)) return;
    min = std::min(min, v);
    max = std::max(max, v);
  }
};

// What one pass over the file found; positions kept when they fit the budget.
struct FileSummary {
  io::PointTable schema;
  std::uint64_t points = 0;
  Range axis[3];
  std::vector<Range> attributes;
  std::vector<Vec3> positions;
  bool positions_kept = true;
};

FileSummary summarise(const fs::path& file, std::uint64_t budget) {
  const auto reader = io::open_point_reader(file);
  FileSummary s;
  s.schema = reader->schema();
  s.attributes.resize(s.schema.attributes.size());
  // The estimate of the defaults needs every position and its neighbour lists (about 220
  // bytes a point at k 48); beyond the budget only the pass's own figures are given.
  const std::uint64_t keep_at_most = budget / 220;
  io::PointTable chunk;
  while (reader->read(chunk, 1u << 16) > 0) {
    throw_if_interrupted();
    for (const Vec3& p : chunk.positions)
      for (int c = 0; c < 3; ++c) s.axis[c].add(p[c]);
    for (std::size_t a = 0; a < chunk.attributes.size(); ++a)
      for (const double v : chunk.attributes[a].values) s.attributes[a].add(v);
    s.points += chunk.size();
    if (s.positions_kept && s.points <= keep_at_most) {
      s.positions.insert(s.positions.end(), chunk.positions.begin(), chunk.positions.end());
    } else {
      s.positions_kept = false;
      s.positions = {};
    }
  }
  return s;
}

std::string format_text(const fs::path& file, const io::PointTable& schema) {
  if (schema.las) {
    return "LAS 1." + std::to_string(schema.las->version_minor) + ", point format " +
           std::to_string(schema.las->point_format);
  }
  if (schema.ply) {
    const char* encoding = schema.ply->encoding == io::PlyEncoding::Ascii                ? "ascii"
                           : schema.ply->encoding == io::PlyEncoding::BinaryLittleEndian ? "binary little endian"
                                                                                         : "binary big endian";
    return std::string("PLY, ") + encoding + ", " + (schema.position_type == io::ScalarType::Float32 ? "float" : "double") +
           " coordinates";
  }
  if (schema.text) {
    std::string separator = schema.text->separator == "\t" ? "tab" : "'" + schema.text->separator + "'";
    return "text (" + file.extension().string() + "), " + (schema.text->header ? "header line" : "no header") +
           ", separated by " + separator;
  }
  return "points";
}

// The defaults' choices for the cloud (SmoothParams{}: automatic k, eps; the finish).
struct DefaultsEstimate {
  NoiseEstimate noise;
  int k = 0;
  double eps = 0.0;
};

DefaultsEstimate estimate_defaults(std::span<const Vec3> positions) {
  DefaultsEstimate d;
  d.noise = estimate_noise(positions);
  d.k = k_for_noise_ratio(d.noise.ratio);  // automatic_k: the minimum without a ratio
  NeighborParams neighbors = SmoothParams{}.neighbors;
  neighbors.k = d.k;
  if (positions.size() > static_cast<std::size_t>(d.k)) d.eps = build_neighborhoods(positions, neighbors).eps;
  return d;
}

JsonObject file_json(const fs::path& file, const FileSummary& s, const DefaultsEstimate* d) {
  JsonObject j;
  j.add("file", file.string()).add("format", format_text(file, s.schema)).add("points", static_cast<long long>(s.points));
  JsonObject bounds;
  for (int c = 0; c < 3; ++c) {
    const char* name = c == 0 ? "x" : c == 1 ? "y" : "z";
    bounds.add(name, JsonObject().add("min", s.axis[c].min).add("max", s.axis[c].max));
  }
  j.add("bounds", bounds);
  if (s.schema.quantization) {
    const io::PositionQuantization& q = *s.schema.quantization;
    j.add("scale", JsonObject().add("x", q.scale.x()).add("y", q.scale.y()).add("z", q.scale.z()));
    j.add("offset", JsonObject().add("x", q.offset.x()).add("y", q.offset.y()).add("z", q.offset.z()));
  }
  if (s.schema.las) j.add("crs", crs_of(*s.schema.las));
  JsonObject attributes;
  for (std::size_t a = 0; a < s.schema.attributes.size(); ++a) {
    const io::Attribute& attribute = s.schema.attributes[a];
    attributes.add(attribute.name, JsonObject()
                                       .add("type", io::scalar_name(attribute.type))
                                       .add("min", s.attributes[a].min)
                                       .add("max", s.attributes[a].max));
  }
  j.add("attributes", attributes);
  if (d != nullptr) {
    const bool coarse = coarse_level_runs(d->noise.ratio);
    const QuadricProjectionParams finish = finish_after(SmoothParams{}, coarse);
    j.add("spacing", d->noise.spacing).add("noise_ratio", d->noise.ratio).add("noise", d->noise.ratio * d->noise.spacing);
    j.add("defaults", JsonObject()
                          .add("k", d->k)
                          .add("eps", d->eps)
                          .add("coarse_level", coarse)
                          .add("finish", JsonObject()
                                               .add("k", finish.k)
                                               .add("degree", finish.degree)
                                               .add("iterations", finish.iterations)
                                               .add("early_degree", finish.early_degree)
                                               .add("early_iterations", finish.early_iterations)
                                               .add("passes", finish.passes)));
  }
  return j;
}

void print_file(const fs::path& file, const FileSummary& s, const DefaultsEstimate* d) {
  std::printf("%s: %s, %s points\n", file.string().c_str(), format_text(file, s.schema).c_str(),
              count_text(s.points).c_str());
  if (s.points > 0) {
    const double diagonal = std::hypot(s.axis[0].max - s.axis[0].min, s.axis[1].max - s.axis[1].min,
                                       s.axis[2].max - s.axis[2].min);
    std::printf("  bounds     x [%s, %s]  y [%s, %s]  z [%s, %s]  (diagonal %s)\n",
                format_number(s.axis[0].min).c_str(), format_number(s.axis[0].max).c_str(),
                format_number(s.axis[1].min).c_str(), format_number(s.axis[1].max).c_str(),
                format_number(s.axis[2].min).c_str(), format_number(s.axis[2].max).c_str(),
                format_number(diagonal).c_str());
  }
  if (s.schema.quantization) {
    const io::PositionQuantization& q = *s.schema.quantization;
    std::printf("  scale      %s %s %s   offset %s %s %s\n", format_number(q.scale.x()).c_str(),
                format_number(q.scale.y()).c_str(), format_number(q.scale.z()).c_str(),
                format_number(q.offset.x()).c_str(), format_number(q.offset.y()).c_str(),
                format_number(q.offset.z()).c_str());
  }
  if (s.schema.las) std::printf("  CRS        %s\n", crs_of(*s.schema.las).c_str());
  for (std::size_t a = 0; a < s.schema.attributes.size(); ++a) {
    const io::Attribute& attribute = s.schema.attributes[a];
    const Range& r = s.attributes[a];
    std::printf("  %-24s %-7s", attribute.name.c_str(), std::string(io::scalar_name(attribute.type)).c_str());
    if (r.min <= r.max)
      std::printf(" [%s, %s]\n", format_number(r.min).c_str(), format_number(r.max).c_str());
    else
      std::printf(" (no values)\n");
  }
  if (d == nullptr) {
    std::printf("  spacing, noise and the defaults' choices: not measured (the cloud needs more than "
                "--memory-budget in core; raise it to measure them)\n");
    return;
  }
  if (s.points < 8) return;
  const bool coarse = coarse_level_runs(d->noise.ratio);
  const QuadricProjectionParams finish = finish_after(SmoothParams{}, coarse);
  std::printf("  spacing    %s (median distance to the nearest point)\n", format_number(d->noise.spacing).c_str());
  std::printf("  noise      %s x the spacing = %s (lower quartile over samples)\n",
              format_number(d->noise.ratio).c_str(), format_number(d->noise.ratio * d->noise.spacing).c_str());
  // The passes before the last fit their own degree and reweightings (params_of_pass).
  const auto fits = [](const QuadricProjectionParams& q) {
    const std::string reweighted = q.iterations == 0   ? "not reweighted"
                                   : q.iterations == 1 ? "reweighted once"
                                                       : "reweighted " + std::to_string(q.iterations) + " times";
    return "degree " + std::to_string(q.degree) + ", " + reweighted;
  };
  const std::string last = fits(params_of_pass(finish, finish.passes - 1)), early = fits(params_of_pass(finish, 0));
  const std::string passes = finish.passes == 1 || early == last
                                 ? "(" + last + ")"
                                 : "(the last " + last + "; before it " + early + ")";
  std::printf("  defaults   k %d, eps %s; then the finish: %d pass%s of fits over %d neighbours %s\n", d->k,
              format_number(d->eps).c_str(), finish.passes, finish.passes == 1 ? "" : "es", finish.k, passes.c_str());
  // Where the flow needs many steps even with momentum (docs/coarse-level.md).
  if (coarse)
    std::printf("  coarse     noise of %s spacings or more: the defaults run the flow on %s first "
                "(--no-coarse-level leaves it out)\n",
                format_number(CoarseLevelParams{}.min_noise_ratio).c_str(),
                coarse_sample_text(CoarseLevelParams{}.ratio).c_str());
}

}  // namespace

int run_info(const Args& args) {
  std::string input;
  bool json = false;
  int threads = 0;
  std::uint64_t budget = std::uint64_t{1} << 30;
  ArgumentParser parser("pointfair info",
                        "Describes a point file, or each point file of a folder: format and version, "
                        "point count, bounds, scale and offset and coordinate system (LAS), every "
                        "attribute with its type and range, the sample spacing and noise, and the k "
                        "and eps that 'pointfair smooth' would choose with its defaults.");
  parser.positional("FILE", "A point file (.ply, .las, .laz, .xyz, .txt, .pts, .csv, .asc) or a folder of them.", &input);
  parser.flag("json", "Print the description as JSON on stdout instead of text.", [&] { json = true; });
  parser.value("memory-budget", "SIZE",
               "Largest cloud measured in core for the spacing, noise and defaults (about 220 bytes "
               "a point); a larger one gets the rest. Default 1G.",
               [&](std::string_view v) { budget = parse_size(v, "--memory-budget"); });
  parser.value("threads", "N", "Worker threads (0: all cores). Default 0.",
               [&](std::string_view v) { threads = parse_int(v, "--threads"); });
  parser.example("pointfair info scan.las");
  parser.example("pointfair info scans/ --json");
  if (!parser.parse(args)) return 0;
  set_thread_count(threads);

  std::vector<fs::path> files;
  std::error_code ec;
  if (fs::is_directory(input, ec)) {
    for (const fs::directory_entry& entry : fs::directory_iterator(input, ec))
      if (entry.is_regular_file() && io::is_supported_point_file(entry.path())) files.push_back(entry.path());
    if (ec) throw io::IoError(input + ": cannot list the folder: " + ec.message());
    std::sort(files.begin(), files.end());
    if (files.empty()) throw io::IoError(input + ": no point files (.ply, .las, .laz, .xyz, .txt, .pts, .csv, .asc) in the folder");
  } else {
    io::require_regular_input(input);
    files.push_back(input);
  }

  // Each file in turn; the positions kept for the estimate are dropped once it is made.
  struct Described {
    FileSummary summary;
    std::optional<DefaultsEstimate> defaults;
  };
  std::vector<Described> described;
  std::uint64_t total = 0;
  for (const fs::path& file : files) {
    Described one{summarise(file, budget), std::nullopt};
    if (one.summary.positions_kept) one.defaults = estimate_defaults(one.summary.positions);
    one.summary.positions = {};
    total += one.summary.points;
    if (!json) print_file(file, one.summary, one.defaults ? &*one.defaults : nullptr);
    described.push_back(std::move(one));
  }
  if (!json) {
    if (files.size() > 1)
      std::printf("%s: %zu point files, %s points\n", input.c_str(), files.size(), count_text(total).c_str());
    return 0;
  }
  const auto object = [&](std::size_t i) {
    const Described& one = described[i];
    return file_json(files[i], one.summary, one.defaults ? &*one.defaults : nullptr);
  };
  JsonObject j;
  if (files.size() == 1) {
    j = object(0);
  } else {
    JsonObject each;
    for (std::size_t i = 0; i < files.size(); ++i) each.add(files[i].filename().string(), object(i));
    j.add("folder", input).add("points", static_cast<long long>(total)).add("files", each);
  }
  std::printf("%s\n", j.add("command", "info").add("version", version()).str().c_str());
  return 0;
}

}  // namespace pointfair::cli
