#include "container_export.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "out_of_core.hpp"
#include "run_support.hpp"
#include "pointfair/common/colour.hpp"
#include "pointfair/io/attribute_roles.hpp"
#include "pointfair/io/las.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/io/point_selection.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/container_reader.hpp"

namespace pointfair::cli {

namespace fs = std::filesystem;

namespace {

constexpr std::uint64_t kBlockRows = 1u << 16;

// Calls `f` with blocks of the colour scalar of every point (max |k1|, |k2| or the
// Laplacian norm, as add_result_columns), in row order.
void for_each_scalar_block(const fs::path& container, ColourBy by,
                           const std::function<void(const std::vector<double>&)>& f) {
  const auto file = tiles::h5::File::open(container, false);
  const std::string a = std::string(tiles::layout::run_attributes) + "/";
  const std::uint64_t n = tiles::point_count(file);
  std::vector<double> values, second;
  for (std::uint64_t first = 0; first < n; first += kBlockRows) {
    const std::uint64_t count = std::min(kBlockRows, n - first);
    values.resize(count);
    if (by == ColourBy::Laplacian) {
      file.dataset(a + "laplacian_norm").read_rows(first, count, values.data());
    } else {
      second.resize(count);
      file.dataset(a + "k1").read_rows(first, count, values.data());
      file.dataset(a + "k2").read_rows(first, count, second.data());
      for (std::uint64_t i = 0; i < count; ++i) values[i] = std::max(std::abs(values[i]), std::abs(second[i]));
    }
    f(values);
  }
}

// An order-preserving key of a finite double.
using ChunkVisitor = std::function<void(const io::PointTable&)>;

// A LAS output from a float source (no integer grid of its own) whose grid the options do not
// give (--scale and --offset): the grid depends on the bounds of every point, so a first pass
// measures them, and the LAS writer streams with that grid (the same bytes as writing the
// whole cloud at once).
bool needs_las_bounds(const fs::path& output, const io::PointTable& schema, const OutputOptions& out,
                      std::uint64_t points) {
  return io::point_format_of(output) == io::PointFormat::Las && !schema.quantization &&
         !(out.las.scale && out.las.offset) && points > 0;
}

// las_quantization_for the bounds of the chunks `for_each_chunk` calls its visitor with.
io::PositionQuantization las_grid_of(const std::function<void(const ChunkVisitor&)>& for_each_chunk) {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for_each_chunk([&](const io::PointTable& chunk) {
    for (const Vec3& p : chunk.positions) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  });
  return io::las_quantization_for(lo, hi);
}

std::uint64_t key_of(double v) {
  const auto bits = std::bit_cast<std::uint64_t>(v);
  return (bits >> 63) != 0 ? ~bits : bits | (std::uint64_t{1} << 63);
}
double value_of(std::uint64_t key) {
  const std::uint64_t bits = (key >> 63) != 0 ? key & ~(std::uint64_t{1} << 63) : ~key;
  return std::bit_cast<double>(bits);
}

// colour_by_scalar's low and high (the clip and 1 - clip quantiles of the finite values, at
// the same ranks) in bounded memory: a radix selection, 16 bits per pass.
std::array<double, 2> colour_range(const fs::path& container, ColourBy by, double clip) {
  std::uint64_t finite = 0;
  for_each_scalar_block(container, by, [&](const std::vector<double>& block) {
    for (const double v : block) finite += std::isfinite(v) ? 1 : 0;
  });
  if (finite == 0) return {0.0, 0.0};
  clip = std::clamp(clip, 0.0, 0.5);
  const auto last = static_cast<double>(finite - 1);
  std::array<std::uint64_t, 2> rank{static_cast<std::uint64_t>(std::lround(clip * last)),
                                    static_cast<std::uint64_t>(std::lround((1.0 - clip) * last))};
  std::array<std::uint64_t, 2> prefix{0, 0};
  std::vector<std::uint64_t> histogram(2 * 65536);
  for (int shift = 48; shift >= 0; shift -= 16) {
    std::fill(histogram.begin(), histogram.end(), 0);
    const std::uint64_t high_mask = shift == 48 ? 0 : ~std::uint64_t{0} << (shift + 16);
    for_each_scalar_block(container, by, [&](const std::vector<double>& block) {
      for (const double v : block) {
        if (!std::isfinite(v)) continue;
        const std::uint64_t k = key_of(v);
        for (std::size_t q = 0; q < 2; ++q)
          if ((k & high_mask) == prefix[q]) ++histogram[q * 65536 + ((k >> shift) & 0xFFFF)];
      }
    });
    for (std::size_t q = 0; q < 2; ++q) {
      std::uint64_t digit = 0;
      while (rank[q] >= histogram[q * 65536 + digit]) rank[q] -= histogram[q * 65536 + digit++];
      prefix[q] |= digit << shift;
    }
  }
  return {value_of(prefix[0]), value_of(prefix[1])};
}

// The whole schema of `source`: a LAS file's EVLRs follow its points, and its writer takes them
// when it opens (skipping to the end seeks over the records).
io::PointTable source_schema(const fs::path& source) {
  const auto probe = io::open_point_reader(source);
  if (const auto count = probe->count()) probe->skip(*count);
  return probe->schema();
}

// Points per chunk of a source read with `schema` while its output is written: the chunk, the
// run's part of it and the writer's block within a quarter of `memory_budget`.
std::size_t source_chunk_points(const io::PointTable& schema, std::uint64_t memory_budget) {
  const std::uint64_t point_bytes = 2 * (24 + 8 * static_cast<std::uint64_t>(schema.attributes.size())) + 64;
  return static_cast<std::size_t>(std::clamp<std::uint64_t>(memory_budget / 4 / point_bytes, 1024, kBlockRows));
}

// Writes the `points` points `for_each_chunk` calls its visitor with to `output` (format by
// extension, atomically) with the schema and layout of `source`.
void write_chunks(const fs::path& output, const io::PointTable& schema, std::uint64_t points, const fs::path& source,
                  const OutputOptions& out, const std::function<void(const ChunkVisitor&)>& for_each_chunk) {
  io::WriteOptions write;
  write.input = source;
  write.ply_encoding = ply_encoding(out.encoding);
  write.las = out.las;
  const auto writer = io::open_point_writer(output, schema, points, write);
  for_each_chunk([&](const io::PointTable& chunk) { writer->write(chunk); });
  writer->finish();
}

}  // namespace

ExportSummary export_container(const fs::path& container, const fs::path& output, const OutputOptions& out,
                               const ContainerExport& options, const fs::path& input) {
  ExportSummary summary;
  {
    const auto f = tiles::h5::File::open(container, false);
    summary.has_results = !options.input_positions && tiles::has_finished_run(f) &&
                          f.exists(std::string(tiles::layout::run_attributes) + "/k1");
  }
  const bool colour = summary.has_results && out.colour_by != ColourBy::None;
  // Normals of the input no longer match smoothed positions: the run's replace them.
  const bool stale_normals =
      summary.has_results &&
      !io::normal_columns(tiles::ContainerChunkReader(container, {.original_order = false}).schema()).empty();
  const bool results = summary.has_results && (out.attributes || colour || stale_normals);
  // The curvature columns' type, for every chunk alike: double when any value would not fit
  // float (a cloud at an extreme scale), as in core (curvature_type).
  io::ScalarType curvatures = io::ScalarType::Float32;
  if (results && out.attributes) {
    const auto f = tiles::h5::File::open(container, false);
    const std::string a = std::string(tiles::layout::run_attributes) + "/";
    std::vector<double> values;
    for (const char* name : {"k1", "k2", "mean_curvature", "laplacian_norm"}) {
      const tiles::h5::Dataset d = f.dataset(a + name);
      for (std::uint64_t first = 0; first < d.rows() && curvatures == io::ScalarType::Float32; first += 1u << 16) {
        const std::uint64_t count = std::min<std::uint64_t>(1u << 16, d.rows() - first);
        values.resize(count);
        d.read_rows(first, count, values.data());
        for (const double v : values)
          if (!fits_float(v)) curvatures = io::ScalarType::Float64;
      }
    }
  }
  std::array<double, 2> range{0.0, 0.0};
  if (colour) range = colour_range(container, out.colour_by, out.colour_clip);

  tiles::ContainerChunkReader reader(container, {.original_order = options.original_order,
                                                 .result_positions = !options.input_positions,
                                                 .run_attributes = results});
  // The result columns, without colours: those are added here with the global range.
  OutputOptions columns = out;
  columns.colour_by = ColourBy::None;
  columns.attribute_prefix = attribute_prefix_for(output);
  const auto add_columns = [&](io::PointTable& table, const PointAttributes& a) {
    if (!results) return;
    add_result_columns(table, a, columns, out.attributes, curvatures);
    if (!colour) return;
    std::vector<double> red(table.size()), green(table.size()), blue(table.size());
    for (std::size_t i = 0; i < table.size(); ++i) {
      const double v = out.colour_by == ColourBy::Laplacian ? a.laplacian_norm[i]
                                                             : std::max(std::abs(a.k1[i]), std::abs(a.k2[i]));
      const Rgb c = hue_colour(v, range[0], range[1]);
      red[i] = c[0];
      green[i] = c[1];
      blue[i] = c[2];
    }
    table.set("red", io::ScalarType::UInt8, std::move(red));
    table.set("green", io::ScalarType::UInt8, std::move(green));
    table.set("blue", io::ScalarType::UInt8, std::move(blue));
  };

  io::PointTable schema = reader.schema();
  add_columns(schema, PointAttributes{});
  summary.points = *reader.count();
  const std::size_t chunk_points = reader.chunk_points_for(options.memory_budget);
  if (needs_las_bounds(output, schema, out, summary.points)) {
    // A first pass (in row order) over the container.
    tiles::ContainerChunkReader first(container, {.original_order = false,
                                                  .result_positions = !options.input_positions});
    schema.quantization = las_grid_of([&](const ChunkVisitor& visit) {
      io::PointTable chunk;
      while (first.read(chunk, chunk_points) > 0) visit(chunk);
    });
  }
  io::WriteOptions write;
  write.input = input;
  write.ply_encoding = ply_encoding(out.encoding);
  write.las = out.las;
  const auto writer = io::open_point_writer(output, schema, summary.points, write);
  io::PointTable chunk;
  while (reader.read(chunk, chunk_points) > 0) {
    add_columns(chunk, reader.run_attributes());
    writer->write(chunk);
  }
  writer->finish();
  return summary;
}

SelectedExportSummary export_selected(const fs::path& container, const fs::path& source,
                                      const io::PointSelection& selection, const fs::path& output,
                                      const OutputOptions& out, std::uint64_t memory_budget) {
  SelectedExportSummary summary;
  io::PointTable schema = source_schema(source);
  summary.points = count_points(source);
  const bool normals = !container.empty() && !io::normal_columns(schema).empty();
  const std::size_t chunk_points = source_chunk_points(schema, memory_budget);
  const auto changed = [&] {
    return io::IoError(source.string() + ": changed during the run (its selected points no longer match " +
                       container.string() + ")");
  };
  OutputOptions columns = out;
  columns.colour_by = ColourBy::None;
  // Calls `f` with every chunk of the output, in the source's order.
  const auto for_each_chunk = [&](const std::function<void(const io::PointTable&)>& f) {
    const auto reader = io::open_point_reader(source);
    std::unique_ptr<tiles::ContainerChunkReader> run;
    if (!container.empty())
      run = std::make_unique<tiles::ContainerChunkReader>(
          container, tiles::ContainerReaderOptions{.original_order = true, .result_positions = true,
                                                   .run_attributes = normals});
    summary.selected = summary.moved = 0;
    io::PointTable chunk, part;
    while (reader->read(chunk, chunk_points) > 0) {
      const std::vector<std::size_t> rows = io::selected_rows(chunk, selection, source);
      if (!rows.empty()) {
        if (!run || run->read(part, rows.size()) != rows.size()) throw changed();
        if (normals) add_result_columns(part, run->run_attributes(), columns, false);
        for (std::size_t j = 0; j < rows.size(); ++j)
          summary.moved += part.positions[j] != chunk.positions[rows[j]] ? 1 : 0;
        io::splice_rows(chunk, rows, part);
        summary.selected += rows.size();
      }
      f(chunk);
    }
    if (run && run->read(part, 1) != 0) throw changed();
  };
  if (needs_las_bounds(output, schema, out, summary.points)) schema.quantization = las_grid_of(for_each_chunk);
  write_chunks(output, schema, summary.points, source, out, for_each_chunk);
  return summary;
}

void export_folder(const fs::path& container, const std::vector<fs::path>& sources, const std::vector<fs::path>& outputs,
                   const OutputOptions& out, std::uint64_t memory_budget) {
  std::vector<io::PointTable> schemas;
  std::vector<std::uint64_t> counts;
  bool normals_anywhere = false;
  for (const fs::path& source : sources) {
    schemas.push_back(source_schema(source));
    counts.push_back(count_points(source));
    normals_anywhere = normals_anywhere || !io::normal_columns(schemas.back()).empty();
  }
  // Refused before any file is written when the counts alone tell the files apart.
  const std::uint64_t held = tiles::point_count(tiles::h5::File::open(container, false));
  const std::uint64_t total = std::accumulate(counts.begin(), counts.end(), std::uint64_t{0});
  if (held != total)
    throw io::IoError(container.string() + ": holds " + std::to_string(held) + " points, the folder's files " +
                      std::to_string(total) + ": they are not the files it was imported from");
  // One pass over the run's points in their original order: file after file, as imported.
  tiles::ContainerChunkReader run(
      container, {.original_order = true, .result_positions = true, .run_attributes = normals_anywhere});
  OutputOptions columns = out;
  columns.colour_by = ColourBy::None;
  for (std::size_t f = 0; f < sources.size(); ++f) {
    const fs::path& source = sources[f];
    const io::PointTable& schema = schemas[f];
    const std::uint64_t points = counts[f];
    const bool normals = !io::normal_columns(schema).empty();
    const std::size_t chunk_points = source_chunk_points(schema, memory_budget);
    // One pass over the source (a LAS output has the source's own grid: no pass for bounds).
    write_chunks(outputs[f], schema, points, source, out, [&](const ChunkVisitor& visit) {
      const auto reader = io::open_point_reader(source);
      io::PointTable chunk, part;
      while (const std::size_t got = reader->read(chunk, chunk_points)) {
        if (run.read(part, got) != got)
          throw io::IoError(source.string() + ": changed during the run (it has more points than " +
                            container.string() + " holds for it)");
        chunk.positions.swap(part.positions);
        if (normals) add_result_columns(chunk, run.run_attributes(), columns, false);
        visit(chunk);
      }
    });
  }
  io::PointTable rest;
  if (run.read(rest, 1) != 0)
    throw io::IoError(container.string() + ": holds more points than the folder's files (a file changed during the run)");
}

}  // namespace pointfair::cli
