#include "pointfair/tiles/export.hpp"

#include <algorithm>
#include <limits>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "pointfair/io/attribute_roles.hpp"
#include "pointfair/io/las.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/container_reader.hpp"

namespace pointfair::tiles {

namespace fs = std::filesystem;

namespace {

constexpr std::uint64_t kBlockRows = 1u << 16;

using ChunkVisitor = std::function<void(const io::PointTable&)>;

// A LAS output from a float source (no integer grid of its own) whose grid the options do not
// give (scale and offset): the grid depends on the bounds of every point, so a first pass
// measures them, and the LAS writer streams with that grid (the same bytes as writing the
// whole cloud at once).
bool needs_las_bounds(const fs::path& output, const io::PointTable& schema, const io::WriteOptions& write,
                      std::uint64_t points) {
  return io::point_format_of(output) == io::PointFormat::Las && !schema.quantization &&
         !(write.las.scale && write.las.offset) && points > 0;
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

// A source's whole schema and its point count, from one reader: a LAS file's EVLRs follow its
// points, and its writer takes them when it opens (skipping to the end seeks over the
// records); a text file, whose header gives no count, is read through once.
struct SourceLayout {
  io::PointTable schema;
  std::uint64_t points = 0;
};

SourceLayout source_layout(const fs::path& source) {
  const auto probe = io::open_point_reader(source);
  SourceLayout layout;
  if (const auto count = probe->count()) {
    probe->skip(*count);
    layout.points = *count;
  } else {
    io::PointTable chunk;
    while (probe->read(chunk, 1u << 16) > 0) {
    }
    layout.points = probe->points_read();
  }
  layout.schema = probe->schema();
  return layout;
}

// Points of a source chunk: a quarter of the budget for the chunk and the run's part of it.
std::size_t source_chunk_points(const io::PointTable& schema, std::uint64_t memory_budget) {
  const std::uint64_t point_bytes = 2 * (24 + 8 * static_cast<std::uint64_t>(schema.attributes.size())) + 64;
  return static_cast<std::size_t>(std::clamp<std::uint64_t>(memory_budget / 4 / point_bytes, 1024, kBlockRows));
}

// The input's normals no longer match the moved points: the run's replace them.
void refresh_from_run(io::PointTable& part, const ContainerChunkReader& run) {
  if (run.run_attributes().normal.size() == part.size()) io::refresh_normals(part, run.run_attributes().normal);
}

}  // namespace

std::uint64_t export_points(const fs::path& container, const fs::path& output, const StreamExportOptions& options) {
  ContainerChunkReader reader(container, {.original_order = options.original_order,
                                          .result_positions = !options.input_positions,
                                          .run_attributes = options.run_attributes});
  const auto add_columns = [&](io::PointTable& table, const PointAttributes& results) {
    if (options.columns) options.columns(table, results);
  };
  io::PointTable schema = reader.schema();
  add_columns(schema, PointAttributes{});
  const std::uint64_t points = *reader.count();
  const std::size_t chunk_points = reader.chunk_points_for(options.memory_budget);
  if (needs_las_bounds(output, schema, options.write, points)) {
    // A first pass (in row order) over the container.
    ContainerChunkReader first(container, {.original_order = false, .result_positions = !options.input_positions});
    schema.quantization = las_grid_of([&](const ChunkVisitor& visit) {
      io::PointTable chunk;
      while (first.read(chunk, chunk_points) > 0) visit(chunk);
    });
  }
  const auto writer = io::open_point_writer(output, schema, points, options.write);
  io::PointTable chunk;
  while (reader.read(chunk, chunk_points) > 0) {
    add_columns(chunk, reader.run_attributes());
    writer->write(chunk);
  }
  writer->finish();
  return points;
}

SelectedExportReport export_selected(const fs::path& container, const fs::path& source,
                                     const io::PointSelection& selection, const fs::path& output,
                                     const io::WriteOptions& write, std::uint64_t memory_budget) {
  SelectedExportReport summary;
  SourceLayout layout = source_layout(source);
  io::PointTable& schema = layout.schema;
  summary.points = layout.points;
  const bool normals = !container.empty() && !io::normal_columns(schema).empty();
  const std::size_t chunk_points = source_chunk_points(schema, memory_budget);
  const auto changed = [&] {
    return io::IoError(source.string() + ": changed during the run (its selected points no longer match " +
                       container.string() + ")");
  };
  // Calls `f` with every chunk of the output, in the source's order.
  const auto for_each_chunk = [&](const std::function<void(const io::PointTable&)>& f) {
    const auto reader = io::open_point_reader(source);
    std::unique_ptr<ContainerChunkReader> run;
    if (!container.empty())
      run = std::make_unique<ContainerChunkReader>(
          container, ContainerReaderOptions{.original_order = true, .result_positions = true,
                                            .run_attributes = normals});
    summary.selected = summary.moved = 0;
    io::PointTable chunk, part;
    while (reader->read(chunk, chunk_points) > 0) {
      const std::vector<std::size_t> rows = io::selected_rows(chunk, selection, source);
      if (!rows.empty()) {
        if (!run || run->read(part, rows.size()) != rows.size()) throw changed();
        if (normals) refresh_from_run(part, *run);
        for (std::size_t j = 0; j < rows.size(); ++j)
          summary.moved += part.positions[j] != chunk.positions[rows[j]] ? 1 : 0;
        io::splice_rows(chunk, rows, part);
        summary.selected += rows.size();
      }
      f(chunk);
    }
    if (run && run->read(part, 1) != 0) throw changed();
  };
  if (needs_las_bounds(output, schema, write, summary.points)) schema.quantization = las_grid_of(for_each_chunk);
  const auto writer = io::open_point_writer(output, schema, summary.points, write);
  for_each_chunk([&](const io::PointTable& chunk) { writer->write(chunk); });
  writer->finish();
  return summary;
}

void export_folder(const fs::path& container, const std::vector<fs::path>& sources, const std::vector<fs::path>& outputs,
                   const io::WriteOptions& write, std::uint64_t memory_budget) {
  std::vector<io::PointTable> schemas;
  std::vector<std::uint64_t> counts;
  bool normals_anywhere = false;
  for (const fs::path& source : sources) {
    SourceLayout layout = source_layout(source);
    schemas.push_back(std::move(layout.schema));
    counts.push_back(layout.points);
    normals_anywhere = normals_anywhere || !io::normal_columns(schemas.back()).empty();
  }
  // Refused before any file is written when the counts alone tell the files apart.
  const std::uint64_t held = point_count(h5::File::open(container, false));
  const std::uint64_t total = std::accumulate(counts.begin(), counts.end(), std::uint64_t{0});
  if (held != total)
    throw io::IoError(container.string() + ": holds " + std::to_string(held) + " points, the folder's files " +
                      std::to_string(total) + ": they are not the files it was imported from");
  // One pass over the run's points in their original order: file after file, as imported.
  ContainerChunkReader run(container,
                           {.original_order = true, .result_positions = true, .run_attributes = normals_anywhere});
  for (std::size_t f = 0; f < sources.size(); ++f) {
    const fs::path& source = sources[f];
    const bool normals = !io::normal_columns(schemas[f]).empty();
    const std::size_t chunk_points = source_chunk_points(schemas[f], memory_budget);
    // The output has the source's format: a LAS output takes the source's own grid.
    io::WriteOptions file_write = write;
    file_write.input = source;
    const auto writer = io::open_point_writer(outputs[f], schemas[f], counts[f], file_write);
    const auto reader = io::open_point_reader(source);
    io::PointTable chunk, part;
    while (const std::size_t got = reader->read(chunk, chunk_points)) {
      if (run.read(part, got) != got)
        throw io::IoError(source.string() + ": changed during the run (it has more points than " +
                          container.string() + " holds for it)");
      chunk.positions.swap(part.positions);
      if (normals) refresh_from_run(chunk, run);
      writer->write(chunk);
    }
    writer->finish();
  }
  io::PointTable rest;
  if (run.read(rest, 1) != 0)
    throw io::IoError(container.string() + ": holds more points than the folder's files (a file changed during the run)");
}

}  // namespace pointfair::tiles
