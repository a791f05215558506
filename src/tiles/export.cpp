#include "pointfair/tiles/export.hpp"

#include <algorithm>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "pointfair/io/attribute_roles.hpp"
#include "pointfair/io/las.hpp"
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
  // The source's whole schema: a LAS file's EVLRs follow its points, and its writer takes them
  // when it opens (skipping to the end seeks over the records).
  io::PointTable schema;
  {
    const auto probe = io::open_point_reader(source);
    if (const auto count = probe->count()) probe->skip(*count);
    schema = probe->schema();
  }
  summary.points = io::count_points(source);
  const bool normals = !container.empty() && !io::normal_columns(schema).empty();
  const std::uint64_t point_bytes = 2 * (24 + 8 * static_cast<std::uint64_t>(schema.attributes.size())) + 64;
  const auto chunk_points =
      static_cast<std::size_t>(std::clamp<std::uint64_t>(memory_budget / 4 / point_bytes, 1024, kBlockRows));
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
        // The input's normals no longer match the moved points: the run's replace them.
        if (normals && run->run_attributes().normal.size() == part.size())
          io::refresh_normals(part, run->run_attributes().normal);
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

}  // namespace pointfair::tiles
