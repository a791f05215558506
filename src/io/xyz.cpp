#include "pointfair/io/xyz.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "file_reader.hpp"
#include "io_error.hpp"
#include "number_text.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "table_checks.hpp"

namespace pointfair::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

constexpr std::size_t kTextFlushBytes = std::size_t{1} << 20;

// Splits on ',' or ';' when the line has one (fields trimmed, empty fields kept so they are
// reported), else on runs of whitespace.
void split_fields(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
  if (line.find_first_of(",;") != std::string_view::npos) {
    for (;;) {
      const std::size_t end = line.find_first_of(",;");
      fields.push_back(trim(line.substr(0, end)));
      if (end == std::string_view::npos) break;
      line.remove_prefix(end + 1);
    }
    return;
  }
  for (std::string_view token = next_token(line); !token.empty(); token = next_token(line)) {
    fields.push_back(token);
  }
}

std::string lower(std::string_view text) {
  std::string result(text);
  for (char& c : result) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return result;
}

// A header name written by a spreadsheet may be quoted.
std::string_view unquote(std::string_view name) {
  if (name.size() >= 2 && (name.front() == '"' || name.front() == '\'') &&
      name.back() == name.front()) {
    name = trim(name.substr(1, name.size() - 2));
  }
  return name;
}

bool all_numbers(const std::vector<std::string_view>& fields) {
  double ignored = 0;
  return std::all_of(fields.begin(), fields.end(),
                     [&](std::string_view field) { return parse_double(field, ignored); });
}

std::optional<std::uint64_t> point_count(const std::vector<std::string_view>& fields) {
  if (fields.size() != 1) return std::nullopt;
  std::uint64_t count = 0;
  const std::string_view text = fields.front();
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), count);
  if (error != std::errc{} || end != text.data() + text.size()) return std::nullopt;
  return count;
}

std::string at_line(const FileReader& reader) {
  return "line " + std::to_string(reader.line_number()) + ": ";
}

// Which column feeds what: coordinate[c] is the column of x, y, z; every other column
// becomes attribute `attribute_of[column]`.
struct Layout {
  std::size_t columns = 0;
  std::size_t coordinate[3] = {0, 1, 2};
  std::vector<std::size_t> attribute_of;  // npos for coordinate columns
};

constexpr std::size_t kNone = static_cast<std::size_t>(-1);

Layout layout_from_header(const FileReader& reader, const std::vector<std::string_view>& fields,
                          PointTable& table) {
  Layout layout;
  layout.columns = fields.size();
  layout.attribute_of.assign(fields.size(), kNone);
  bool has[3] = {false, false, false};
  for (std::size_t column = 0; column < fields.size(); ++column) {
    std::string name(unquote(fields[column]));
    if (name.empty()) name = "field_" + std::to_string(column);
    const std::string folded = lower(name);
    if (folded == "x" || folded == "y" || folded == "z") {
      const int c = folded[0] - 'x';
      if (has[c]) fail(reader.path(), at_line(reader) + "header names column " + folded + " twice");
      has[c] = true;
      layout.coordinate[c] = column;
      continue;
    }
    if (table.find(name) != nullptr) {
      fail(reader.path(), at_line(reader) + "header names column '" + name + "' twice");
    }
    layout.attribute_of[column] = table.attributes.size();
    table.attributes.push_back(Attribute{name, ScalarType::Float64, {}});
  }
  for (int c = 0; c < 3; ++c) {
    if (!has[c]) {
      fail(reader.path(), at_line(reader) + "header lacks column " + std::string(1, char('x' + c)));
    }
  }
  return layout;
}

Layout layout_without_header(const FileReader& reader, std::size_t columns, PointTable& table) {
  if (columns < 3) {
    fail(reader.path(),
         at_line(reader) + "expected at least 3 columns (x y z), found " + std::to_string(columns));
  }
  Layout layout;
  layout.columns = columns;
  layout.attribute_of.assign(columns, kNone);
  for (std::size_t column = 3; column < columns; ++column) {
    std::string name = "field_" + std::to_string(column);
    if (columns == 6) name = std::string(1, 'n') + char('x' + (column - 3));
    layout.attribute_of[column] = table.attributes.size();
    table.attributes.push_back(Attribute{name, ScalarType::Float64, {}});
  }
  return layout;
}

void add_row(const FileReader& reader, const Layout& layout,
             const std::vector<std::string_view>& fields, std::vector<double>& values,
             PointTable& table) {
  if (fields.size() != layout.columns) {
    fail(reader.path(), at_line(reader) + "expected " + std::to_string(layout.columns) +
                            " columns, found " + std::to_string(fields.size()));
  }
  values.resize(fields.size());
  for (std::size_t column = 0; column < fields.size(); ++column) {
    if (!parse_double(fields[column], values[column])) {
      fail(reader.path(),
           at_line(reader) + "'" + std::string(fields[column]) + "' is not a number");
    }
  }
  Vec3 position;
  for (int c = 0; c < 3; ++c) {
    position[c] = values[layout.coordinate[c]];
    if (!std::isfinite(position[c])) {
      fail(reader.path(), at_line(reader) + "non-finite coordinate (" +
                              std::string(non_finite_name(position[c])) + ")");
    }
  }
  table.positions.push_back(position);
  for (std::size_t column = 0; column < fields.size(); ++column) {
    if (layout.attribute_of[column] != kNone) {
      table.attributes[layout.attribute_of[column]].values.push_back(values[column]);
    }
  }
}

}  // namespace

PointTable read_xyz(const fs::path& file, const ReadOptions& options) {
  FileReader reader(file);
  PointTable table;
  table.position_type = ScalarType::Float64;
  std::optional<Layout> layout;
  std::optional<std::uint64_t> declared_count;
  bool seen_content = false;
  std::vector<std::string_view> fields;
  std::vector<double> values;
  std::string_view line;
  while (reader.next_line(line)) {
    line = trim(line);
    if (line.empty() || line.front() == '#') continue;
    split_fields(line, fields);
    if (!layout) {
      if (!seen_content) {
        seen_content = true;
        declared_count = point_count(fields);
        if (declared_count) continue;
      }
      if (!all_numbers(fields)) {
        layout = layout_from_header(reader, fields, table);
        continue;
      }
      layout = layout_without_header(reader, fields.size(), table);
    }
    add_row(reader, *layout, fields, values, table);
  }
  if (!seen_content)
    fail(file, reader.size() == 0 ? "empty file" : "no points (only comments or blank lines)");
  if (declared_count && *declared_count != table.size()) {
    warn(options, file,
         "first line declares " + std::to_string(*declared_count) + " points, the file has " +
             std::to_string(table.size()));
  }
  return table;
}

namespace {

void check_xyz_names(const fs::path& file, const PointTable& table) {
  for (std::size_t i = 0; i < table.attributes.size(); ++i) {
    const std::string& name = table.attributes[i].name;
    const bool readable = !name.empty() && name.front() != '#' && name.front() != '"' &&
                          name.front() != '\'' &&
                          std::none_of(name.begin(), name.end(), [](char c) {
                            return c == ',' || c == ';' || static_cast<unsigned char>(c) <= ' ';
                          });
    if (!readable) fail(file, "attribute name '" + name + "' cannot be written to a header line");
    const std::string folded = lower(name);
    if (folded == "x" || folded == "y" || folded == "z") {
      fail(file, "attribute name '" + name + "' clashes with a coordinate");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (table.attributes[j].name == name) fail(file, "duplicate attribute '" + name + "'");
    }
  }
}

}  // namespace

void write_xyz(const fs::path& file, const PointTable& table) {
  check_table(file, table);
  check_xyz_names(file, table);
  const char separator = lower(file.extension().string()) == ".csv" ? ',' : ' ';
  write_file_atomically(file, [&](FileSink& sink) {
    std::string text;
    text.reserve(kTextFlushBytes + 4096);
    if (!table.attributes.empty()) {
      text += "x";
      text += separator;
      text += "y";
      text += separator;
      text += "z";
      for (const Attribute& attribute : table.attributes) {
        text += separator;
        text += attribute.name;
      }
      text += '\n';
    }
    for (std::size_t i = 0; i < table.size(); ++i) {
      for (int c = 0; c < 3; ++c) {
        if (c > 0) text += separator;
        append_number(text, table.positions[i][c]);
      }
      for (const Attribute& attribute : table.attributes) {
        text += separator;
        append_number(text, attribute.values[i]);
      }
      text += '\n';
      if (text.size() >= kTextFlushBytes) {
        sink.write(text);
        text.clear();
      }
    }
    sink.write(text);
  });
}

}  // namespace pointfair::io
