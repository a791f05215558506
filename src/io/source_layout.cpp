#include "pointfair/io/source_layout.hpp"

#include <charconv>
#include <optional>
#include <vector>

namespace pointfair::io {

namespace {

// Bytes up to ' ' and '%' as "%XX": a field holds no blank and no line end.
std::string escaped(std::string_view text) {
  constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  out.reserve(text.size() + 1);
  out += '=';  // an empty field stays a field
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte <= ' ' || c == '%') {
      out += '%';
      out += kHex[byte >> 4];
      out += kHex[byte & 15];
    } else {
      out += c;
    }
  }
  return out;
}

bool unescaped(std::string_view field, std::string& out) {
  if (field.empty() || field.front() != '=') return false;
  out.clear();
  for (std::size_t i = 1; i < field.size(); ++i) {
    if (field[i] != '%') {
      out += field[i];
      continue;
    }
    unsigned value = 0;
    if (i + 2 >= field.size()) return false;
    const auto [end, error] = std::from_chars(field.data() + i + 1, field.data() + i + 3, value, 16);
    if (error != std::errc{} || end != field.data() + i + 3) return false;
    out += static_cast<char>(value);
    i += 2;
  }
  return true;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> fields;
  while (!line.empty()) {
    const std::size_t end = line.find(' ');
    fields.push_back(line.substr(0, end));
    if (end == std::string_view::npos) break;
    line.remove_prefix(end + 1);
  }
  return fields;
}

bool to_int(std::string_view text, int& value) {
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  return error == std::errc{} && end == text.data() + text.size();
}

}  // namespace

std::string encode_source_layout(const PointTable& table) {
  std::string out;
  if (const auto& text = table.text) {
    out += "text " + std::to_string(text->header ? 1 : 0) + " " + std::to_string(text->count_line ? 1 : 0) + " " +
           escaped(text->separator) + " " + escaped(text->line_end) + "\n";
    for (const TextColumn& column : text->columns) {
      out += "column " + std::to_string(column.axis) + " " + std::to_string(column.decimals) + " " +
             escaped(column.name) + " " + escaped(column.header) + "\n";
    }
  }
  if (const auto& ply = table.ply) {
    out += "ply " + std::to_string(static_cast<int>(ply->encoding)) + "\n";
    for (const std::string& line : ply->header_lines) out += "line " + escaped(line) + "\n";
    for (const std::string& name : ply->properties) out += "property " + escaped(name) + "\n";
  }
  return out;
}

bool decode_source_layout(std::string_view encoded, PointTable& table) {
  std::optional<TextLayout> text;
  std::optional<PlyLayout> ply;
  while (!encoded.empty()) {
    const std::size_t end = encoded.find('\n');
    if (end == std::string_view::npos) return false;
    const std::vector<std::string_view> f = split(encoded.substr(0, end));
    encoded.remove_prefix(end + 1);
    if (f.empty()) return false;
    int a = 0, b = 0;
    std::string s1, s2;
    if (f[0] == "text" && f.size() == 5 && to_int(f[1], a) && to_int(f[2], b) && unescaped(f[3], s1) &&
        unescaped(f[4], s2) && !text) {
      text.emplace();
      text->header = a != 0;
      text->count_line = b != 0;
      text->separator = s1;
      text->line_end = s2;
    } else if (f[0] == "column" && f.size() == 5 && text && to_int(f[1], a) && to_int(f[2], b) && a >= -1 &&
               a <= 2 && unescaped(f[3], s1) && unescaped(f[4], s2)) {
      text->columns.push_back(TextColumn{s1, a, s2, b});
    } else if (f[0] == "ply" && f.size() == 2 && to_int(f[1], a) && a >= 0 && a <= 2 && !ply) {
      ply.emplace();
      ply->encoding = static_cast<PlyEncoding>(a);
    } else if (f[0] == "line" && f.size() == 2 && ply && unescaped(f[1], s1)) {
      ply->header_lines.push_back(s1);
    } else if (f[0] == "property" && f.size() == 2 && ply && unescaped(f[1], s1)) {
      ply->properties.push_back(s1);
    } else {
      return false;
    }
  }
  table.text = std::move(text);
  table.ply = std::move(ply);
  return true;
}

}  // namespace pointfair::io
