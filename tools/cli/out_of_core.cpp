#include "out_of_core.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <string>

#include "arguments.hpp"
#include "pointfair/io/file_lock.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/io/point_folder.hpp"
#include "pointfair/neighbors/neighborhood_size.hpp"

namespace pointfair::cli {

bool is_container_path(const std::filesystem::path& path) {
  std::string e = path.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e == ".h5" || e == ".hdf5";
}

std::uint64_t parse_size(std::string_view text, std::string_view what) {
  std::uint64_t value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  std::string unit(ptr, end);
  for (char& c : unit) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (unit.ends_with("IB")) unit.resize(unit.size() - 2);
  else if (unit.size() == 2 && unit.back() == 'B') unit.resize(1);
  int shift = -1;
  if (unit.empty() || unit == "B") shift = 0;
  else if (unit == "K") shift = 10;
  else if (unit == "M") shift = 20;
  else if (unit == "G") shift = 30;
  else if (unit == "T") shift = 40;
  if (text.empty() || ec != std::errc() || ptr == text.data() || shift < 0 || value == 0 ||
      value > (std::uint64_t{1} << (63 - shift)))
    throw UsageError(std::string(what) + " expects a positive size such as 256M or 2G, got '" +
                     std::string(text) + "'");
  return value << shift;
}

std::uint64_t input_file_size(const std::filesystem::path& file) {
  if (std::filesystem::is_directory(file)) {
    std::uint64_t total = 0;
    for (const auto& f : io::point_files_in(file)) total += input_file_size(f);
    return total;
  }
  io::require_regular_input(file);
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(file, ec);
  if (ec) throw io::IoError(file.string() + ": cannot open: " + ec.message());
  return size;
}

std::uint64_t count_points(const std::filesystem::path& file) {
  const auto reader = std::filesystem::is_directory(file) ? io::open_folder_reader(io::point_files_in(file))
                                                         : io::open_point_reader(file);
  if (reader->count()) return *reader->count();
  io::PointTable chunk;
  while (reader->read(chunk, 1u << 16) > 0) {
  }
  return reader->points_read();
}

std::uint64_t in_core_bytes(std::uint64_t points, int k, bool compensated) {
  // Positions (input, current, next, before, and the plain update of a compensated step),
  // neighbour lists twice while reordering, the table's attribute columns.
  return points * ((compensated ? 5 : 4) * 24 + 8 * static_cast<std::uint64_t>(k) + 64);
}

std::uint64_t in_core_finish_bytes(std::uint64_t points, const QuadricProjectionParams& q) {
  // The output positions, the normals, the input kept for the placement
  // (SmoothParams::placement) and the copy in Morton order with the order and its inverse
  // (finish_with_quadrics), the normals' lists, the pass's grid, and one block of the fits'
  // lists (4 bytes an entry, a count per row).
  const std::uint64_t near = static_cast<std::uint64_t>(std::min(q.k, q.normal_neighbors));
  const std::uint64_t block = std::min<std::uint64_t>(points, kQuadricBlock);
  return points * (4 * 24 + 8 + 4 * near + 2 + 50) + block * (4 * static_cast<std::uint64_t>(q.k) + 2);
}

bool fits_in_core(std::uint64_t points, const SmoothParams& params, std::uint64_t budget) {
  const bool compensated = params.shrink_compensation > 0.0;
  // The automatic k is not known before the cloud is read: size for the largest it picks.
  // In core the quadric finish adds its normals and short lists and one block of its
  // k-long lists; out of core, tiles hold k-long lists for every point.
  const int flow_k = params.neighbors.k == 0 ? kAutoKMax : params.neighbors.k;
  const std::uint64_t in_core = in_core_bytes(points, flow_k, compensated) +
                                (params.finish ? in_core_finish_bytes(points, *params.finish) : 0);
  return in_core <= budget;
}

}  // namespace pointfair::cli
