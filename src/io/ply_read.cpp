// PLY reader: header, then each element in file order; only "vertex" is kept.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "file_reader.hpp"
#include "io_error.hpp"
#include "number_text.hpp"
#include "ply_header.hpp"
#include "pointfair/io/ply.hpp"
#include "pointfair/io/point_chunks.hpp"
#include "scalar_codec.hpp"
#include "table_checks.hpp"

namespace pointfair::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

constexpr std::size_t kBlockBytes = std::size_t{4} << 20;
// Bound on the up-front reservation for ASCII bodies, whose size per vertex is unknown.
constexpr std::size_t kAsciiReserve = std::size_t{1} << 16;

// Where one vertex property goes: a coordinate (0..2) or an attribute.
struct Column {
  ScalarType type = ScalarType::Float64;
  int coordinate = -1;
  std::size_t attribute = 0;
  std::size_t offset = 0;  // in a binary record
  const std::string* name = nullptr;
};

struct VertexLayout {
  std::vector<Column> columns;
  std::size_t record_size = 0;
};

std::string count_of(std::uint64_t count, const std::string& element_name) {
  return std::to_string(count) + " " + (count == 1 ? element_name : plural_of(element_name));
}

[[noreturn]] void fail_truncated(const fs::path& file, bool ascii, const PlyElement& element,
                                 std::uint64_t complete) {
  fail(file, std::string("truncated ") + (ascii ? "ascii" : "binary") + " body: expected " +
                 count_of(element.count, element.name) + ", file ends after " +
                 std::to_string(complete));
}

// Checks the vertex properties and adds one empty attribute per non-coordinate property.
VertexLayout plan_vertices(const fs::path& file, const PlyElement& vertex, PointTable& table) {
  VertexLayout layout;
  bool has[3] = {false, false, false};
  bool any_double = false;
  for (const PlyProperty& property : vertex.properties) {
    if (property.is_list) {
      fail(file, "vertex property '" + property.name + "' is a list, which is not supported");
    }
    Column column;
    column.type = property.type;
    column.offset = layout.record_size;
    column.name = &property.name;
    layout.record_size += scalar_size(property.type);
    if (property.name == "x" || property.name == "y" || property.name == "z") {
      column.coordinate = property.name[0] - 'x';
      has[column.coordinate] = true;
      if (property.type != ScalarType::Float32 && property.type != ScalarType::Float64) {
        fail(file, "vertex property " + property.name + " has type " +
                       std::string(scalar_name(property.type)) + " (expected float or double)");
      }
      any_double = any_double || property.type == ScalarType::Float64;
    } else {
      column.attribute = table.attributes.size();
      table.attributes.push_back(Attribute{property.name, property.type, {}});
    }
    layout.columns.push_back(column);
  }
  for (int c = 0; c < 3; ++c) {
    if (!has[c]) fail(file, std::string("vertex element lacks property ") + char('x' + c));
  }
  table.position_type = any_double ? ScalarType::Float64 : ScalarType::Float32;
  return layout;
}

void check_point_limit(const fs::path& file, std::uint64_t count) {
  constexpr std::uint64_t limit = std::numeric_limits<Index>::max();
  if (count > limit) {
    fail(file, std::to_string(count) + " vertices exceed the limit of " + std::to_string(limit) +
                   " points per file");
  }
}

// Checked before anything is allocated, so a corrupt count cannot trigger a huge allocation.
void check_binary_count(FileReader& reader, const PlyElement& vertex, const VertexLayout& layout) {
  const std::uint64_t available = reader.remaining() / layout.record_size;
  if (vertex.count > available) fail_truncated(reader.path(), false, vertex, available);
  check_point_limit(reader.path(), vertex.count);
}

// Appends vertices [first, first + count) of the body to `table`, a block at a time.
void read_binary_vertices(FileReader& reader, const PlyElement& vertex, const VertexLayout& layout,
                          bool swap, std::size_t first, std::size_t count, std::vector<char>& block,
                          PointTable& table) {
  const fs::path& file = reader.path();
  const std::size_t record = layout.record_size;
  const std::size_t start = table.positions.size();
  table.positions.resize(start + count);
  for (Attribute& attribute : table.attributes) attribute.values.resize(start + count);

  const std::size_t block_records = std::max<std::size_t>(1, kBlockBytes / record);
  block.resize(std::min(count, block_records) * record);
  for (std::size_t done = 0; done < count; done += block_records) {
    const std::size_t records = std::min(block_records, count - done);
    const std::size_t got = reader.read(block.data(), records * record);
    if (got != records * record) fail_truncated(file, false, vertex, first + done + got / record);
    const std::size_t at = start + done;
    for (const Column& column : layout.columns) {
      double* out = column.coordinate >= 0 ? table.positions[at].data() + column.coordinate
                                           : table.attributes[column.attribute].values.data() + at;
      const std::size_t out_stride = column.coordinate >= 0 ? 3 : 1;
      decode_column(column.type, swap, block.data() + column.offset, record, records, out,
                    out_stride);
    }
    for (std::size_t i = at; i < at + records; ++i) {
      check_finite_point(file, table.positions[i], first + (i - start));
    }
    check_attribute_values(file, table, at, first + done, "vertex");
  }
}

// The next line that is not blank; false at end of file.
bool next_data_line(FileReader& reader, std::string_view& line) {
  while (reader.next_line(line)) {
    if (!trim(line).empty()) return true;
  }
  return false;
}

std::string at_line(const FileReader& reader) {
  return "line " + std::to_string(reader.line_number()) + ": ";
}

bool parse_value(ScalarType type, std::string_view token, double& value) {
  if (type == ScalarType::Float32) {
    float parsed = 0;
    if (!parse_float(token, parsed)) return false;
    value = parsed;
    return true;
  }
  return parse_double(token, value) && fits_type(type, value);
}

// Each value takes at least one digit and one separator (the last line may lack its
// newline); a count beyond that bound is rejected before anything is reserved.
void check_ascii_count(FileReader& reader, const PlyElement& vertex, const VertexLayout& layout) {
  const std::uint64_t bound = (reader.remaining() + 1) / (2 * layout.columns.size());
  if (vertex.count > bound) {
    fail(reader.path(), "header declares " + count_of(vertex.count, vertex.name) + " but only " +
                            std::to_string(reader.remaining()) + " bytes follow the header");
  }
  check_point_limit(reader.path(), vertex.count);
}

// Appends vertices [first, first + count) of the body to `table`.
void read_ascii_vertices(FileReader& reader, const PlyElement& vertex, const VertexLayout& layout,
                         std::size_t first, std::size_t count, PointTable& table) {
  const fs::path& file = reader.path();
  const std::size_t values = layout.columns.size();
  const std::size_t reserve = table.positions.size() + std::min(count, kAsciiReserve);
  table.positions.reserve(reserve);
  for (Attribute& attribute : table.attributes) attribute.values.reserve(reserve);

  std::string_view line;
  for (std::size_t i = first; i < first + count; ++i) {
    if (!next_data_line(reader, line)) fail_truncated(file, true, vertex, i);
    std::string_view rest = line;
    Vec3 position = Vec3::Zero();
    for (const Column& column : layout.columns) {
      const std::string_view token = next_token(rest);
      if (token.empty()) {
        fail(file, at_line(reader) + "vertex " + std::to_string(i) + " has fewer than " +
                       std::to_string(values) + " values");
      }
      double value = 0;
      if (!parse_value(column.type, token, value)) {
        fail(file, at_line(reader) + "'" + std::string(token) + "' is not a valid " +
                       std::string(scalar_name(column.type)) + " (property '" + *column.name +
                       "')");
      }
      check_text_value(file, at_line(reader), token, value, column.type, "property '" + *column.name + "'",
                       column.coordinate >= 0);
      if (column.coordinate >= 0) {
        position[column.coordinate] = value;
      } else {
        table.attributes[column.attribute].values.push_back(value);
      }
    }
    if (!next_token(rest).empty()) {
      fail(file, at_line(reader) + "vertex " + std::to_string(i) + " has more than " +
                     std::to_string(values) + " values");
    }
    table.positions.push_back(position);
    check_finite_point(file, position, i, "vertex",
                       " in line " + std::to_string(reader.line_number()));
  }
}

// A list length as stored in the file; lengths must be non-negative integers.
bool list_length(double value, std::uint64_t& length) {
  // 2^64: beyond it the conversion below would be undefined.
  if (!(value >= 0 && value < 18446744073709551616.0) || value != std::trunc(value)) return false;
  length = static_cast<std::uint64_t>(value);
  return true;
}

void skip_binary_element(FileReader& reader, const PlyElement& element, bool swap) {
  const fs::path& file = reader.path();
  std::uint64_t min_record = 0;  // bytes of an instance whose lists are all empty
  bool has_list = false;
  for (const PlyProperty& property : element.properties) {
    min_record += scalar_size(property.is_list ? property.count_type : property.type);
    has_list = has_list || property.is_list;
  }
  if (min_record == 0) return;  // no properties: instances take no bytes
  if (element.count > reader.remaining() / min_record) {
    fail(file, "truncated binary body: expected " + count_of(element.count, element.name) +
                   ", file is too short");
  }
  if (!has_list) {
    reader.skip(element.count * min_record);
    return;
  }
  char bytes[8];
  for (std::uint64_t i = 0; i < element.count; ++i) {
    for (const PlyProperty& property : element.properties) {
      if (!property.is_list) {
        const std::size_t size = scalar_size(property.type);
        if (reader.skip(size) != size) fail_truncated(file, false, element, i);
        continue;
      }
      const std::size_t size = scalar_size(property.count_type);
      if (reader.read(bytes, size) != size) fail_truncated(file, false, element, i);
      double stored = 0;
      decode_column(property.count_type, swap, bytes, size, 1, &stored, 1);
      std::uint64_t length = 0;
      if (!list_length(stored, length)) {
        fail(file, element.name + " " + std::to_string(i) + " has an invalid list length");
      }
      const std::uint64_t list_bytes = length * scalar_size(property.type);
      if (reader.skip(list_bytes) != list_bytes) fail_truncated(file, false, element, i);
    }
  }
}

void skip_ascii_element(FileReader& reader, const PlyElement& element) {
  const fs::path& file = reader.path();
  std::string_view line;
  for (std::uint64_t i = 0; i < element.count; ++i) {
    if (!next_data_line(reader, line)) fail_truncated(file, true, element, i);
    const auto too_few = [&] {
      fail(file, at_line(reader) + element.name + " " + std::to_string(i) + " has too few values");
    };
    std::string_view rest = line;
    for (const PlyProperty& property : element.properties) {
      const std::string_view token = next_token(rest);
      if (token.empty()) too_few();
      if (!property.is_list) continue;
      double stored = 0;
      std::uint64_t length = 0;
      if (!parse_double(token, stored) || !list_length(stored, length)) {
        fail(file, at_line(reader) + "bad list length '" + std::string(token) + "'");
      }
      for (std::uint64_t k = 0; k < length; ++k) {
        if (next_token(rest).empty()) too_few();
      }
    }
    if (!next_token(rest).empty()) {
      fail(file, at_line(reader) + element.name + " " + std::to_string(i) + " has too many values");
    }
  }
}

void warn_about_leftovers(FileReader& reader, bool ascii, const ReadOptions& options) {
  if (ascii) {
    std::string_view line;
    if (next_data_line(reader, line)) {
      warn(options, reader.path(),
           "extra data after the body ignored (from line " + std::to_string(reader.line_number()) +
               ")");
    }
  } else if (reader.remaining() > 0) {
    warn(options, reader.path(),
         std::to_string(reader.remaining()) + " bytes of extra data after the body ignored");
  }
}

}  // namespace

namespace {

// The vertex element is read in chunks; the elements before it are skipped when the reader
// opens, those after it when the last vertex has been read.
class PlyChunkReader final : public PointChunkReader {
 public:
  PlyChunkReader(const fs::path& file, const ReadOptions& options)
      : PointChunkReader(file), options_(options), reader_(file) {
    header_ = read_ply_header(reader_);
    const auto vertex =
        std::find_if(header_.elements.begin(), header_.elements.end(),
                     [](const PlyElement& element) { return element.name == "vertex"; });
    if (vertex == header_.elements.end()) fail(file, "no vertex element");
    vertex_ = static_cast<std::size_t>(vertex - header_.elements.begin());
    layout_ = plan_vertices(file, *vertex, schema_);
    ascii_ = header_.encoding == PlyEncoding::Ascii;
    swap_ = needs_swap(header_.encoding == PlyEncoding::BinaryBigEndian);
    PlyLayout source{.encoding = header_.encoding, .header_lines = header_.header_lines, .properties = {}};
    for (const PlyProperty& property : vertex->properties) source.properties.push_back(property.name);
    schema_.ply = std::move(source);
    for (std::size_t e = 0; e < vertex_; ++e) skip(header_.elements[e]);
    if (ascii_) {
      check_ascii_count(reader_, *vertex, layout_);
    } else {
      check_binary_count(reader_, *vertex, layout_);
    }
    // plan_vertices keeps pointers to the property names: they live in header_.
  }

  std::optional<std::uint64_t> count() const override { return vertices().count; }

 protected:
  bool seek_over(std::uint64_t points) override {
    // Binary vertices are records of one size (list properties are refused); the last
    // vertex is read, not skipped, so the elements after it are still checked.
    if (ascii_ || points_read_ + points >= vertices().count) return false;
    const std::uint64_t bytes = points * layout_.record_size;
    if (reader_.skip(bytes) != bytes) fail_truncated(path_, false, vertices(), points_read_);
    return true;
  }

  std::size_t append(PointTable& chunk, std::size_t max_points) override {
    const std::uint64_t left = vertices().count - points_read_;
    const auto count = static_cast<std::size_t>(std::min<std::uint64_t>(left, max_points));
    const auto first = static_cast<std::size_t>(points_read_);
    if (count > 0) {
      if (ascii_) {
        read_ascii_vertices(reader_, vertices(), layout_, first, count, chunk);
      } else {
        read_binary_vertices(reader_, vertices(), layout_, swap_, first, count, block_, chunk);
      }
    }
    if (points_read_ + count == vertices().count && !finished_) finish();
    return count;
  }

 private:
  const PlyElement& vertices() const { return header_.elements[vertex_]; }

  void skip(const PlyElement& element) {
    if (ascii_) {
      skip_ascii_element(reader_, element);
    } else {
      skip_binary_element(reader_, element, swap_);
    }
  }

  void finish() {
    finished_ = true;
    block_ = std::vector<char>();
    for (std::size_t e = vertex_ + 1; e < header_.elements.size(); ++e) skip(header_.elements[e]);
    warn_about_leftovers(reader_, ascii_, options_);
    for (std::size_t e = 0; e < header_.elements.size(); ++e) {
      const PlyElement& element = header_.elements[e];
      if (e != vertex_ && element.count > 0) {
        warn(options_, path_, count_of(element.count, element.name) + " ignored");
      }
    }
  }

  ReadOptions options_;
  FileReader reader_;
  PlyHeader header_;
  std::size_t vertex_ = 0;
  VertexLayout layout_;
  bool ascii_ = false;
  bool swap_ = false;
  bool finished_ = false;
  std::vector<char> block_;
};

}  // namespace

std::unique_ptr<PointChunkReader> open_ply_reader(const fs::path& file, const ReadOptions& options) {
  return std::make_unique<PlyChunkReader>(file, options);
}

PointTable read_ply(const fs::path& file, const ReadOptions& options) {
  PlyChunkReader reader(file, options);
  PointTable table = reader.schema();
  // One chunk of every vertex; the count was checked against the file size when it opened.
  reader.read(table, static_cast<std::size_t>(std::max<std::uint64_t>(1, *reader.count())));
  return table;
}

}  // namespace pointfair::io
