#include "ply_header.hpp"

#include <array>
#include <charconv>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "io_error.hpp"
#include "number_text.hpp"
#include "scalar_codec.hpp"

namespace pointfair::io::detail {

namespace {

std::optional<ScalarType> parse_type(std::string_view name) {
  struct Entry {
    std::string_view classic;
    std::string_view sized;
    ScalarType type;
  };
  static constexpr std::array<Entry, 8> kTypes{{
      {"char", "int8", ScalarType::Int8},
      {"uchar", "uint8", ScalarType::UInt8},
      {"short", "int16", ScalarType::Int16},
      {"ushort", "uint16", ScalarType::UInt16},
      {"int", "int32", ScalarType::Int32},
      {"uint", "uint32", ScalarType::UInt32},
      {"float", "float32", ScalarType::Float32},
      {"double", "float64", ScalarType::Float64},
  }};
  for (const Entry& entry : kTypes) {
    if (name == entry.classic || name == entry.sized) return entry.type;
  }
  return std::nullopt;
}

// Splits a header line into at most a few tokens; comments are handled before this.
std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> tokens;
  for (std::string_view token = next_token(line); !token.empty(); token = next_token(line)) {
    tokens.push_back(token);
  }
  return tokens;
}

std::string in_line(const FileReader& reader) {
  return " in line " + std::to_string(reader.line_number());
}

ScalarType property_type(const FileReader& reader, std::string_view name) {
  const std::optional<ScalarType> type = parse_type(name);
  if (!type)
    fail(reader.path(), "unknown property type '" + std::string(name) + "'" + in_line(reader));
  return *type;
}

void add_property(FileReader& reader, PlyHeader& header,
                  const std::vector<std::string_view>& tokens) {
  if (header.elements.empty()) fail(reader.path(), "property before any element" + in_line(reader));
  PlyProperty property;
  if (tokens.size() == 5 && tokens[1] == "list") {
    property.is_list = true;
    property.count_type = property_type(reader, tokens[2]);
    property.type = property_type(reader, tokens[3]);
    property.name = tokens[4];
    if (!is_integer_type(property.count_type)) {
      fail(reader.path(), "list count type must be an integer type" + in_line(reader));
    }
  } else if (tokens.size() == 3 && tokens[1] != "list") {
    property.type = property_type(reader, tokens[1]);
    property.name = tokens[2];
  } else {
    fail(reader.path(), "malformed property line" + in_line(reader));
  }
  PlyElement& element = header.elements.back();
  for (const PlyProperty& other : element.properties) {
    if (other.name == property.name) {
      fail(reader.path(), "duplicate property '" + property.name + "'" + in_line(reader));
    }
  }
  element.properties.push_back(std::move(property));
}

void add_element(FileReader& reader, PlyHeader& header,
                 const std::vector<std::string_view>& tokens) {
  if (tokens.size() != 3) fail(reader.path(), "malformed element line" + in_line(reader));
  PlyElement element;
  element.name = tokens[1];
  const std::string_view count = tokens[2];
  const auto [end, error] =
      std::from_chars(count.data(), count.data() + count.size(), element.count);
  if (error != std::errc{} || end != count.data() + count.size()) {
    fail(reader.path(), "bad element count '" + std::string(count) + "'" + in_line(reader));
  }
  for (const PlyElement& other : header.elements) {
    if (other.name == element.name) {
      fail(reader.path(), "duplicate element '" + element.name + "'" + in_line(reader));
    }
  }
  header.elements.push_back(std::move(element));
}

void set_format(FileReader& reader, PlyHeader& header, std::string_view line,
                const std::vector<std::string_view>& tokens) {
  const auto bad = [&] {
    fail(reader.path(), "bad format line '" + std::string(trim(line)) + "'" + in_line(reader));
  };
  if (tokens.size() != 3 || tokens[2] != "1.0") bad();
  if (tokens[1] == "ascii") {
    header.encoding = PlyEncoding::Ascii;
  } else if (tokens[1] == "binary_little_endian") {
    header.encoding = PlyEncoding::BinaryLittleEndian;
  } else if (tokens[1] == "binary_big_endian") {
    header.encoding = PlyEncoding::BinaryBigEndian;
  } else {
    bad();
  }
}

}  // namespace

PlyHeader read_ply_header(FileReader& reader) {
  if (reader.size() == 0) fail(reader.path(), "empty file");
  std::string_view line;
  if (!reader.next_line(line) || trim(line) != "ply") {
    if (line.starts_with("ply\r"))
      fail(reader.path(), "line 1: carriage return inside a line (CR-only line endings?): convert the header to LF "
                          "or CRLF line endings");
    if (line.starts_with("\xEF\xBB\xBFply"))
      fail(reader.path(), "line 1: a UTF-8 byte-order mark before 'ply': remove it (a PLY file starts with 'ply')");
    fail(reader.path(), "not a PLY file (missing 'ply' magic)");
  }
  PlyHeader header;
  bool has_format = false;
  while (reader.next_line(line)) {
    const std::vector<std::string_view> tokens = split(line);
    if (tokens.empty()) continue;
    const std::string_view keyword = tokens.front();
    if (keyword == "comment" || keyword == "obj_info") {
      std::string_view text = line;
      while (!text.empty() && (text.back() == '\r' || text.back() == '\n')) text.remove_suffix(1);
      header.header_lines.emplace_back(text);
      continue;
    }
    if (keyword == "end_header") {
      if (!has_format) fail(reader.path(), "header has no format line");
      return header;
    }
    if (keyword == "format") {
      set_format(reader, header, line, tokens);
      has_format = true;
    } else if (keyword == "element") {
      add_element(reader, header, tokens);
    } else if (keyword == "property") {
      add_property(reader, header, tokens);
    } else {
      fail(reader.path(),
           "unknown header keyword '" + std::string(keyword) + "'" + in_line(reader));
    }
  }
  fail(reader.path(), "header ends without end_header");
}

std::string plural_of(const std::string& element_name) {
  if (element_name == "vertex") return "vertices";
  return element_name + "s";
}

}  // namespace pointfair::io::detail
