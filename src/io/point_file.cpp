#include "pointfair/io/point_file.hpp"

#include <cctype>
#include <string>

#include "io_error.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/las.hpp"
#include "pointfair/io/point_folder.hpp"
#include "pointfair/io/xyz.hpp"

namespace pointfair::io {

namespace fs = std::filesystem;

namespace {

std::string lower_extension(const fs::path& file) {
  std::string extension = file.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension;
}

using Format = PointFormat;

Format format_of(const fs::path& file) {
  if (const std::optional<PointFormat> format = point_format_of(file)) return *format;
  // Formats users will reasonably try get a clearer message than "unknown".
  const std::string extension = lower_extension(file);
  if (extension == ".h5" || extension == ".hdf5") {
    detail::fail(file, "HDF5 files are not supported by this build yet");
  }
  detail::fail(file, "unknown file extension '" + file.extension().string() +
                         "' (expected .ply, .las, .xyz, .txt, .pts, .csv or .asc)");
}

}  // namespace

std::optional<PointFormat> point_format_of(const fs::path& file) {
  const std::string extension = lower_extension(file);
  if (extension == ".ply") return PointFormat::Ply;
  if (extension == ".xyz" || extension == ".txt" || extension == ".pts" || extension == ".csv" || extension == ".asc") {
    return PointFormat::Text;
  }
  // LAZ is LAS with compressed records: the LAS reader and writer handle both.
  if (extension == ".las" || extension == ".laz") return PointFormat::Las;
  return std::nullopt;
}

bool is_supported_point_file(const fs::path& file) {
  const std::optional<PointFormat> format = point_format_of(file);
  return format.has_value();
}

PointTable read_points(const fs::path& file, const ReadOptions& options) {
  switch (format_of(file)) {
    case Format::Ply: return read_ply(file, options);
    case Format::Las: return read_las(file, options);
    case Format::Text: break;
  }
  return read_xyz(file, options);
}

void write_points(const fs::path& file, const PointTable& table, const WriteOptions& options) {
  const Format format = format_of(file);
  if (!options.input.empty()) require_distinct(options.input, file);
  if (format == Format::Ply) {
    write_ply(file, table, options.ply_encoding);
  } else if (format == Format::Las) {
    write_las(file, table, options.las);
  } else {
    write_xyz(file, table);
  }
}

std::unique_ptr<PointChunkReader> open_point_reader(const fs::path& file, const ReadOptions& options) {
  switch (format_of(file)) {
    case Format::Ply: return open_ply_reader(file, options);
    case Format::Las: return open_las_reader(file, options);
    case Format::Text: break;
  }
  return open_xyz_reader(file, options);
}

std::unique_ptr<PointChunkWriter> open_point_writer(const fs::path& file, const PointTable& schema,
                                                    std::uint64_t count, const WriteOptions& options) {
  const Format format = format_of(file);
  if (!options.input.empty()) require_distinct(options.input, file);
  if (format == Format::Ply) return open_ply_writer(file, schema, count, options.ply_encoding);
  if (format == Format::Las) {
    return open_las_writer(file, schema, count, options.las);
  }
  return open_xyz_writer(file, schema, count);
}

std::uint64_t count_points(const fs::path& file) {
  const auto reader = fs::is_directory(file) ? open_folder_reader(point_files_in(file)) : open_point_reader(file);
  if (reader->count()) return *reader->count();
  PointTable chunk;
  while (reader->read(chunk, 1u << 16) > 0) {
  }
  return reader->points_read();
}

}  // namespace pointfair::io
