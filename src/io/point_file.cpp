#include "pointfair/io/point_file.hpp"

#include <cctype>
#include <string>

#include "io_error.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/xyz.hpp"

namespace pointfair::io {

namespace fs = std::filesystem;

namespace {

enum class Format { Ply, Text };

std::string lower_extension(const fs::path& file) {
  std::string extension = file.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension;
}

Format format_of(const fs::path& file) {
  const std::string extension = lower_extension(file);
  if (extension == ".ply") return Format::Ply;
  if (extension == ".xyz" || extension == ".txt" || extension == ".pts" || extension == ".csv") {
    return Format::Text;
  }
  // Formats users will reasonably try get a clearer message than "unknown".
  if (extension == ".las" || extension == ".laz") {
    detail::fail(file, "LAS/LAZ files are not supported by this build yet");
  }
  if (extension == ".h5" || extension == ".hdf5") {
    detail::fail(file, "HDF5 files are not supported by this build yet");
  }
  detail::fail(file, "unknown file extension '" + file.extension().string() +
                         "' (expected .ply, .xyz, .txt, .pts or .csv)");
}

}  // namespace

bool is_supported_point_file(const fs::path& file) {
  const std::string extension = lower_extension(file);
  return extension == ".ply" || extension == ".xyz" || extension == ".txt" || extension == ".pts" ||
         extension == ".csv";
}

PointTable read_points(const fs::path& file, const ReadOptions& options) {
  return format_of(file) == Format::Ply ? read_ply(file, options) : read_xyz(file, options);
}

void write_points(const fs::path& file, const PointTable& table, const WriteOptions& options) {
  const Format format = format_of(file);
  if (!options.input.empty()) require_distinct(options.input, file);
  if (format == Format::Ply) {
    write_ply(file, table, options.ply_encoding);
  } else {
    write_xyz(file, table);
  }
}

}  // namespace pointfair::io
