// Triangle meshes from OFF and PLY files (ground truth for `pointfair eval`, sources for
// `pointfair generate --mesh`). Separate from ply_read.cpp, which reads point files only.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "file_reader.hpp"
#include "io_error.hpp"
#include "number_text.hpp"
#include "ply_header.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/mesh.hpp"
#include "scalar_codec.hpp"

namespace pointfair::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// Adds polygon `corners` as a fan of triangles after checking the indices.
void add_polygon(const fs::path& file, TriangleMesh& mesh, const std::vector<double>& corners,
                 std::uint64_t face) {
  if (corners.size() < 3) fail(file, "face " + std::to_string(face) + " has fewer than 3 corners");
  std::vector<Index> ids;
  ids.reserve(corners.size());
  for (const double c : corners) {
    if (!(c >= 0) || c != std::floor(c) || c >= static_cast<double>(mesh.vertices.size())) {
      fail(file, "face " + std::to_string(face) + ": vertex index out of range");
    }
    ids.push_back(static_cast<Index>(c));
  }
  for (std::size_t k = 1; k + 1 < ids.size(); ++k) mesh.triangles.push_back({ids[0], ids[k], ids[k + 1]});
}

Vec3 checked_vertex(const fs::path& file, double x, double y, double z, std::uint64_t v) {
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
    fail(file, "vertex " + std::to_string(v) + ": non-finite coordinate");
  }
  return {x, y, z};
}

// Next non-empty line without its comment; false at the end of the file.
bool next_content_line(FileReader& reader, std::string_view& line) {
  while (reader.next_line(line)) {
    const auto hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    line = trim(line);
    if (!line.empty()) return true;
  }
  return false;
}

double number_token(FileReader& reader, std::string_view& rest) {
  const std::string_view token = next_token(rest);
  double value = 0;
  if (token.empty() || !parse_double(token, value)) {
    fail(reader.path(), "line " + std::to_string(reader.line_number()) + ": expected a number");
  }
  return value;
}

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

// One scalar of a binary PLY body.
double read_binary_scalar(FileReader& reader, ScalarType type, bool swap) {
  char bytes[8];
  const std::size_t size = scalar_size(type);
  if (reader.read(bytes, size) != size) fail(reader.path(), "truncated binary body");
  double value = 0;
  decode_column(type, swap, bytes, size, 1, &value, 1);
  return value;
}

}  // namespace

TriangleMesh read_off_mesh(const fs::path& file) {
  FileReader reader(file);
  std::string_view line;
  if (!next_content_line(reader, line)) fail(file, "empty file");
  std::string_view rest = line;
  if (next_token(rest) != "OFF") fail(file, "not an OFF file (first word must be OFF)");
  if (trim(rest).empty()) {
    if (!next_content_line(reader, line)) fail(file, "missing counts line");
    rest = line;
  }
  const double nv = number_token(reader, rest), nf = number_token(reader, rest);
  if (!(nv >= 0 && nf >= 0) || nv != std::floor(nv) || nf != std::floor(nf) || nv > 4e9 || nf > 4e9) {
    fail(file, "bad vertex or face count");
  }
  // Each vertex line takes at least 6 bytes, each face at least 8: bound the reservation.
  if (nv * 6 + nf * 8 > static_cast<double>(reader.size())) fail(file, "counts exceed the file size");
  TriangleMesh mesh;
  const auto vertex_count = static_cast<std::uint64_t>(nv), face_count = static_cast<std::uint64_t>(nf);
  mesh.vertices.reserve(vertex_count);
  for (std::uint64_t v = 0; v < vertex_count; ++v) {
    if (!next_content_line(reader, line)) fail(file, "file ends after " + std::to_string(v) + " vertices");
    rest = line;
    const double x = number_token(reader, rest), y = number_token(reader, rest), z = number_token(reader, rest);
    mesh.vertices.push_back(checked_vertex(file, x, y, z, v));
  }
  std::vector<double> corners;
  for (std::uint64_t f = 0; f < face_count; ++f) {
    if (!next_content_line(reader, line)) fail(file, "file ends after " + std::to_string(f) + " faces");
    rest = line;
    const double n = number_token(reader, rest);
    if (!(n >= 0 && n < 1e6) || n != std::floor(n)) fail(file, "face " + std::to_string(f) + ": bad corner count");
    corners.clear();
    for (int c = 0; c < static_cast<int>(n); ++c) corners.push_back(number_token(reader, rest));
    add_polygon(file, mesh, corners, f);
  }
  return mesh;
}

TriangleMesh read_ply_mesh(const fs::path& file) {
  FileReader reader(file);
  const PlyHeader header = read_ply_header(reader);
  const bool ascii = header.encoding == PlyEncoding::Ascii;
  const bool swap = needs_swap(header.encoding == PlyEncoding::BinaryBigEndian);
  TriangleMesh mesh;
  bool have_faces = false;
  std::vector<double> corners;
  std::string_view line;
  for (const PlyElement& element : header.elements) {
    const bool is_vertex = element.name == "vertex", is_face = element.name == "face";
    int coordinate_of[3] = {-1, -1, -1};
    int list_property = -1;
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const auto& property = element.properties[p];
      if (is_vertex && !property.is_list && property.name.size() == 1 && property.name[0] >= 'x' &&
          property.name[0] <= 'z') {
        coordinate_of[property.name[0] - 'x'] = static_cast<int>(p);
      }
      if (is_face && property.is_list && (property.name == "vertex_indices" || property.name == "vertex_index")) {
        list_property = static_cast<int>(p);
      }
    }
    if (is_vertex && (coordinate_of[0] < 0 || coordinate_of[1] < 0 || coordinate_of[2] < 0)) {
      fail(file, "vertex element without x, y and z");
    }
    if (is_face && list_property < 0) fail(file, "face element without a vertex_indices list");
    if (element.count > reader.remaining()) fail(file, "element count exceeds the file size");
    if (is_vertex) mesh.vertices.reserve(element.count);
    std::vector<double> values(element.properties.size());
    for (std::uint64_t r = 0; r < element.count; ++r) {
      corners.clear();
      std::string_view rest;
      if (ascii) {
        if (!reader.next_line(line)) fail(file, "truncated ascii body in element " + element.name);
        rest = line;
      }
      for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const auto& property = element.properties[p];
        auto read_one = [&](ScalarType type) {
          return ascii ? number_token(reader, rest) : read_binary_scalar(reader, type, swap);
        };
        if (property.is_list) {
          const double n = read_one(property.count_type);
          if (!(n >= 0 && n < 1e6)) fail(file, "bad list length in element " + element.name);
          for (int c = 0; c < static_cast<int>(n); ++c) {
            const double value = read_one(property.type);
            if (static_cast<int>(p) == list_property) corners.push_back(value);
          }
        } else {
          values[p] = read_one(property.type);
        }
      }
      if (is_vertex) {
        mesh.vertices.push_back(checked_vertex(file, values[static_cast<std::size_t>(coordinate_of[0])],
                                               values[static_cast<std::size_t>(coordinate_of[1])],
                                               values[static_cast<std::size_t>(coordinate_of[2])], r));
      } else if (is_face) {
        add_polygon(file, mesh, corners, r);
      }
    }
    have_faces = have_faces || (is_face && element.count > 0);
  }
  if (!have_faces) fail(file, "no faces: not a triangle mesh");
  return mesh;
}

TriangleMesh read_mesh(const fs::path& file) {
  const std::string extension = lower(file.extension().string());
  if (extension == ".off") return read_off_mesh(file);
  if (extension == ".ply") return read_ply_mesh(file);
  fail(file, "unknown mesh extension '" + file.extension().string() + "' (expected .off or .ply)");
}

void write_off_mesh(const fs::path& file, const TriangleMesh& mesh) {
  write_file_atomically(file, [&](FileSink& sink) {
    std::string text = "OFF\n" + std::to_string(mesh.vertices.size()) + " " +
                       std::to_string(mesh.triangles.size()) + " 0\n";
    for (const Vec3& v : mesh.vertices) {
      append_number(text, v.x());
      text += ' ';
      append_number(text, v.y());
      text += ' ';
      append_number(text, v.z());
      text += '\n';
      if (text.size() > (1u << 20)) {
        sink.write(text);
        text.clear();
      }
    }
    for (const auto& t : mesh.triangles) {
      text += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) + "\n";
      if (text.size() > (1u << 20)) {
        sink.write(text);
        text.clear();
      }
    }
    sink.write(text);
  });
}

}  // namespace pointfair::io
