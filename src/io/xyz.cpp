#include "pointfair/io/xyz.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_set>
#include <utility>
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

// Splits on ';' when the line has one, else on ',' when it has one (fields trimmed, empty
// fields kept so they are reported), else on runs of whitespace. A line with ';' is split on
// ';' alone: its commas are decimal commas ("1,5;2,25"), which are then refused as such
// rather than read as more fields.
void split_fields(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
  const char* delimiters = line.find(';') != std::string_view::npos ? ";" : ",";
  if (line.find_first_of(delimiters) != std::string_view::npos) {
    for (;;) {
      const std::size_t end = line.find_first_of(delimiters);
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

// The text between the first two fields of `line` (trimmed): the delimiter with the blanks
// around it, or the first run of whitespace.
std::string separator_of(std::string_view line) {
  std::size_t begin = line.find(';') != std::string_view::npos ? line.find(';') : line.find(',');
  std::size_t end = begin == std::string_view::npos ? 0 : begin + 1;
  if (begin == std::string_view::npos) {
    begin = 0;
    while (begin < line.size() && !is_space(line[begin])) ++begin;
    end = begin;
  }
  while (begin > 0 && is_space(line[begin - 1])) --begin;
  while (end < line.size() && is_space(line[end])) ++end;
  return begin < end ? std::string(line.substr(begin, end - begin)) : std::string(" ");
}

// Digits after the point of a number written in plain fixed notation ("-12.50": 2, "7": 0);
// -1 for any other spelling ("1e3", "+2", "5.", "nan", "007"), which is then written back in
// the shortest form that reads back exactly.
int decimals_of(std::string_view text) {
  if (!text.empty() && text.front() == '-') text.remove_prefix(1);
  const std::size_t point = text.find('.');
  const std::string_view whole = text.substr(0, point);
  const auto digits = [](std::string_view part) {
    return std::all_of(part.begin(), part.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  if (whole.empty() || !digits(whole) || (whole.size() > 1 && whole.front() == '0')) return -1;
  if (point == std::string_view::npos) return 0;
  const std::string_view fraction = text.substr(point + 1);
  if (fraction.empty() || fraction.size() > 40 || !digits(fraction)) return -1;
  return static_cast<int>(fraction.size());
}

// Which column feeds what: coordinate[c] is the column of x, y, z; every other column
// becomes attribute `attribute_of[column]`.
struct Layout {
  std::size_t columns = 0;
  std::size_t coordinate[3] = {0, 1, 2};
  std::vector<std::size_t> attribute_of;  // npos for coordinate columns
};

constexpr std::size_t kNone = static_cast<std::size_t>(-1);

// CloudCompare's names for the columns it writes (its ASCII export's "//X Y Z R G B Nx Ny
// Nz ..." header) and ours.
constexpr std::pair<std::string_view, std::string_view> kCloudCompareNames[] = {
    {"R", "red"}, {"G", "green"}, {"B", "blue"}, {"A", "alpha"}, {"Nx", "nx"}, {"Ny", "ny"}, {"Nz", "nz"}};

std::string from_cloudcompare(std::string name) {
  for (const auto& [theirs, ours] : kCloudCompareNames)
    if (name == theirs) return std::string(ours);
  return name;
}

std::string to_cloudcompare(const std::string& name) {
  for (const auto& [theirs, ours] : kCloudCompareNames)
    if (name == ours) return std::string(theirs);
  return name;
}

Layout layout_from_header(const FileReader& reader, const std::vector<std::string_view>& fields,
                          PointTable& table) {
  Layout layout;
  layout.columns = fields.size();
  layout.attribute_of.assign(fields.size(), kNone);
  bool has[3] = {false, false, false};
  // CloudCompare's ASCII export starts its header with "//" and names colours and normals
  // its own way.
  const bool cloudcompare = !fields.empty() && fields[0].starts_with("//");
  for (std::size_t column = 0; column < fields.size(); ++column) {
    std::string_view field = fields[column];
    if (column == 0 && cloudcompare) field.remove_prefix(2);
    std::string name(unquote(field));
    if (cloudcompare) name = from_cloudcompare(name);
    if (name.empty()) name = "field_" + std::to_string(column);
    const std::string folded = lower(name);
    if (folded == "x" || folded == "y" || folded == "z") {
      const int c = folded[0] - 'x';
      if (has[c]) fail(reader.path(), at_line(reader) + "header names column " + folded + " twice");
      has[c] = true;
      layout.coordinate[c] = column;
      table.text->columns.push_back(TextColumn{folded, c, std::string(fields[column]), -1});
      continue;
    }
    if (table.find(name) != nullptr) {
      fail(reader.path(), at_line(reader) + "header names column '" + name + "' twice");
    }
    layout.attribute_of[column] = table.attributes.size();
    table.text->columns.push_back(TextColumn{name, -1, std::string(fields[column]), -1});
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
  for (int c = 0; c < 3; ++c) table.text->columns.push_back(TextColumn{std::string(1, char('x' + c)), c, {}, -1});
  for (std::size_t column = 3; column < columns; ++column) {
    std::string name = "field_" + std::to_string(column);
    if (columns == 6) name = std::string(1, 'n') + char('x' + (column - 3));
    layout.attribute_of[column] = table.attributes.size();
    table.text->columns.push_back(TextColumn{name, -1, {}, -1});
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
      const bool decimal_comma = fields[column].find(',') != std::string_view::npos;
      fail(reader.path(), at_line(reader) + "'" + std::string(fields[column]) + "' is not a number" +
                              (decimal_comma ? " (decimal commas are not read: write numbers with a decimal point)"
                                             : ""));
    }
    // Attributes follow the coordinates' rule: finite, and never a number read as another.
    const bool coordinate = layout.attribute_of[column] == kNone;
    check_text_value(reader.path(), at_line(reader), fields[column], values[column], ScalarType::Float64,
                     "column " + std::to_string(column + 1), coordinate);
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

namespace {

// The layout is settled by the first line that is not a comment, a blank or a point count;
// the reader opens by reading up to it (a first data row is kept for the first chunk).
class XyzChunkReader final : public PointChunkReader {
 public:
  XyzChunkReader(const fs::path& file, const ReadOptions& options)
      : PointChunkReader(file), options_(options), reader_(file) {
    schema_.position_type = ScalarType::Float64;
    schema_.text.emplace();
    TextLayout& text = *schema_.text;
    std::string_view line;
    while (!layout_ && next_content_line(line)) {
      if (!seen_content_) {
        seen_content_ = true;
        text.line_end = reader_.line_had_cr() ? "\r\n" : "\n";
        declared_count_ = point_count(fields_);
        text.count_line = declared_count_.has_value();
        if (declared_count_) continue;
      }
      if (!all_numbers(fields_)) {
        // A number written with a decimal comma is not a column name.
        for (const std::string_view field : fields_) {
          std::string dotted(field);
          std::replace(dotted.begin(), dotted.end(), ',', '.');
          double ignored = 0;
          if (field.find(',') != std::string_view::npos && parse_double(dotted, ignored))
            fail(file, at_line(reader_) + "'" + std::string(field) +
                           "' is not a number (decimal commas are not read: write numbers with a decimal point)");
        }
        text.header = true;
        text.separator = separator_of(line);
        layout_ = layout_from_header(reader_, fields_, schema_);
        // The first row too: its spelling of the numbers is part of the schema.
        pending_row_ = next_content_line(line);
        break;
      }
      layout_ = layout_without_header(reader_, fields_.size(), schema_);
      pending_row_ = true;  // fields_ holds the first row
    }
    if (pending_row_) {
      if (fields_.size() > 1) text.separator = separator_of(line);
      for (std::size_t column = 0; column < fields_.size() && column < text.columns.size(); ++column) {
        text.columns[column].decimals = decimals_of(fields_[column]);
      }
    }
    if (!seen_content_)
      fail(file, reader_.size() == 0 ? "empty file" : "no points (only comments or blank lines)");
    if (!layout_) layout_.emplace();  // only a point count: no columns, no points
  }

  std::optional<std::uint64_t> count() const override { return std::nullopt; }

 protected:
  std::size_t append(PointTable& chunk, std::size_t max_points) override {
    std::size_t added = 0;
    if (pending_row_ && max_points > 0) {
      pending_row_ = false;
      add_row(reader_, *layout_, fields_, values_, chunk);
      ++added;
    }
    std::string_view line;
    while (added < max_points && !finished_) {
      if (!next_content_line(line)) {
        finish(points_read_ + added);
        break;
      }
      add_row(reader_, *layout_, fields_, values_, chunk);
      ++added;
    }
    return added;
  }

 private:
  // The next line that is neither blank nor a comment, split into fields_.
  bool next_content_line(std::string_view& line) {
    while (reader_.next_line(line)) {
      if (reader_.line_number() == 1) check_first_line(line);
      line = trim(line);
      // A carriage return inside a line: CR-only line endings (classic Mac OS), which would
      // read the whole file as one line.
      if (line.find('\r') != std::string_view::npos)
        fail(reader_.path(), at_line(reader_) +
                                 "carriage return inside a line (CR-only line endings?): convert the file to LF "
                                 "or CRLF line endings");
      if (line.empty() || line.front() == '#') continue;
      split_fields(line, fields_);
      return true;
    }
    return false;
  }

  // A UTF-8 byte-order mark is skipped (and not written back); UTF-16 text is refused.
  void check_first_line(std::string_view& line) {
    if (line.starts_with("\xEF\xBB\xBF")) line.remove_prefix(3);
    if (line.starts_with("\xFF\xFE") || line.starts_with("\xFE\xFF"))
      fail(reader_.path(), "UTF-16 text is not read: save the file as UTF-8 or ASCII");
  }

  void finish(std::uint64_t total) {
    finished_ = true;
    if (declared_count_ && *declared_count_ != total) {
      warn(options_, path_,
           "first line declares " + std::to_string(*declared_count_) + " points, the file has " +
               std::to_string(total));
    }
  }

  ReadOptions options_;
  FileReader reader_;
  std::optional<Layout> layout_;
  std::optional<std::uint64_t> declared_count_;
  bool seen_content_ = false;
  bool pending_row_ = false;
  bool finished_ = false;
  std::vector<std::string_view> fields_;
  std::vector<double> values_;
};

}  // namespace

std::unique_ptr<PointChunkReader> open_xyz_reader(const fs::path& file, const ReadOptions& options) {
  return std::make_unique<XyzChunkReader>(file, options);
}

PointTable read_xyz(const fs::path& file, const ReadOptions& options) {
  XyzChunkReader reader(file, options);
  PointTable table = reader.schema();
  reader.read(table, static_cast<std::size_t>(-1));
  return table;
}

namespace {

// The names written to a header line must read back as the same columns. `first` skips
// the attributes whose header field is the source's own text (read from that header).
void check_xyz_names(const fs::path& file, const PointTable& table, std::size_t first = 0) {
  // A set, not a scan of the earlier names: a LAS record can carry 65,000 extra bytes.
  std::unordered_set<std::string_view> seen;
  for (std::size_t i = 0; i < table.attributes.size(); ++i) {
    const std::string& name = table.attributes[i].name;
    if (!seen.insert(name).second) fail(file, "duplicate attribute '" + name + "'");
    if (i < first) continue;
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
  }
}

// A column of the output: the coordinate `axis` (0..2) or attribute `attribute`, with the
// header field and number spelling (TextColumn::decimals) it is written with.
struct OutputColumn {
  int axis = -1;
  std::size_t attribute = 0;
  std::string header;
  int decimals = -1;
};

// The source's columns (table.text) that the table still has, in the source's order, then
// the table's other attributes. Sorted so that the attributes with the source's header text
// come first in `sourced` (how many of them there are).
// With `cloudcompare` (a .asc file), the header names not taken from the source are
// CloudCompare's ("//X Y Z R G B Nx Ny Nz ...").
std::vector<OutputColumn> output_columns(const PointTable& table, bool cloudcompare, std::size_t& sourced) {
  std::vector<OutputColumn> columns;
  std::vector<bool> placed(table.attributes.size(), false);
  bool axis_placed[3] = {false, false, false};
  sourced = 0;
  if (table.text) {
    for (const TextColumn& column : table.text->columns) {
      if (column.axis >= 0 && column.axis < 3) {
        if (axis_placed[column.axis]) continue;
        axis_placed[column.axis] = true;
        columns.push_back(OutputColumn{column.axis, 0, column.header, column.decimals});
        continue;
      }
      for (std::size_t a = 0; a < table.attributes.size(); ++a) {
        if (placed[a] || table.attributes[a].name != column.name) continue;
        placed[a] = true;
        columns.push_back(OutputColumn{-1, a, column.header, column.decimals});
        break;
      }
    }
  }
  // A source without all three coordinates (only a point count) or none: x y z first.
  for (int c = 2; c >= 0; --c) {
    if (!axis_placed[c]) columns.insert(columns.begin(), OutputColumn{c, 0, {}, -1});
  }
  for (std::size_t a = 0; a < table.attributes.size(); ++a) {
    if (placed[a]) continue;
    columns.push_back(OutputColumn{-1, a, {}, -1});
  }
  for (OutputColumn& column : columns) {
    if (!column.header.empty()) continue;
    const std::string name = column.axis >= 0 ? std::string(1, static_cast<char>('x' + column.axis))
                                              : table.attributes[column.attribute].name;
    column.header = cloudcompare ? (column.axis >= 0 ? std::string(1, static_cast<char>('X' + column.axis))
                                                     : to_cloudcompare(name))
                                 : name;
  }
  // CloudCompare's header line starts with "//" (a source's own header keeps its text).
  if (cloudcompare && !columns.empty() && !columns.front().header.starts_with("//"))
    columns.front().header.insert(0, "//");
  sourced = static_cast<std::size_t>(std::count(placed.begin(), placed.end(), true));
  return columns;
}

// Appends `value` with `decimals` digits after the point when that text reads back as exactly
// `value` (so a value read from "12.50" is written "12.50" again), else the shortest text
// that does.
void append_spelled(std::string& out, double value, int decimals) {
  if (decimals >= 0 && std::isfinite(value) && std::abs(value) < 1e17) {
    char buffer[64];
    const auto [end, error] = std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::fixed, decimals);
    double back = 0;
    if (error == std::errc{} && parse_double(std::string_view(buffer, static_cast<std::size_t>(end - buffer)), back) &&
        back == value && std::signbit(back) == std::signbit(value)) {
      out.append(buffer, end);
      return;
    }
  }
  append_number(out, value);
}

}  // namespace

namespace {

class XyzChunkWriter final : public PointChunkWriter {
 public:
  XyzChunkWriter(const fs::path& file, const PointTable& schema, std::uint64_t count)
      : path_(file), count_(count) {
    for (const Attribute& attribute : schema.attributes) {
      schema_.attributes.push_back(Attribute{attribute.name, attribute.type, {}});
    }
    schema_.text = schema.text;
    std::size_t sourced = 0;
    columns_ = output_columns(schema_, lower(file.extension().string()) == ".asc", sourced);
    const bool header = schema.text ? schema.text->header : !schema_.attributes.empty();
    // Only names that go into a header line must read back from it; the source's own
    // columns keep their header text (which may be quoted, or hold blanks between commas).
    if (header) {
      std::vector<Attribute> reordered;
      for (const OutputColumn& column : columns_) {
        if (column.axis < 0) reordered.push_back(Attribute{schema_.attributes[column.attribute].name, {}, {}});
      }
      PointTable names;
      names.attributes = std::move(reordered);
      check_xyz_names(file, names, sourced);
    } else {
      check_xyz_names(file, schema_, schema_.attributes.size());
    }
    if (schema.text) {
      separator_ = schema.text->separator;
      line_end_ = schema.text->line_end;
    } else {
      separator_ = lower(file.extension().string()) == ".csv" ? "," : " ";
    }
    file_.emplace(file);
    text_.reserve(kTextFlushBytes + 4096);
    if (schema.text && schema.text->count_line) text_ += std::to_string(count) + line_end_;
    if (header) {
      for (std::size_t c = 0; c < columns_.size(); ++c) {
        if (c > 0) text_ += separator_;
        text_ += columns_[c].header;
      }
      text_ += line_end_;
    }
  }

  void write(const PointTable& chunk) override {
    require_schema(path_, schema_, chunk);
    check_table(path_, chunk, points_written_);
    if (chunk.size() > count_ - points_written_) {
      fail(path_, "more points written than the " + std::to_string(count_) + " declared");
    }
    for (std::size_t i = 0; i < chunk.size(); ++i) {
      for (std::size_t c = 0; c < columns_.size(); ++c) {
        if (c > 0) text_ += separator_;
        const OutputColumn& column = columns_[c];
        append_spelled(text_,
                       column.axis >= 0 ? chunk.positions[i][column.axis] : chunk.attributes[column.attribute].values[i],
                       column.decimals);
      }
      text_ += line_end_;
      if (text_.size() >= kTextFlushBytes) {
        file_->sink().write(text_);
        text_.clear();
      }
    }
    points_written_ += chunk.size();
  }

  void finish() override {
    if (points_written_ != count_) {
      fail(path_, "only " + std::to_string(points_written_) + " of the " + std::to_string(count_) +
                      " declared points were written");
    }
    file_->sink().write(text_);
    text_.clear();
    file_->commit();
  }

 private:
  fs::path path_;
  PointTable schema_;
  std::vector<OutputColumn> columns_;
  std::uint64_t count_ = 0;
  std::string separator_ = " ";
  std::string line_end_ = "\n";
  std::string text_;
  std::optional<AtomicFile> file_;
};

}  // namespace

std::unique_ptr<PointChunkWriter> open_xyz_writer(const fs::path& file, const PointTable& schema,
                                                  std::uint64_t count) {
  return std::make_unique<XyzChunkWriter>(file, schema, count);
}

void write_xyz(const fs::path& file, const PointTable& table) {
  // Checked before the output file is created.
  check_table(file, table);
  XyzChunkWriter writer(file, table, table.size());
  writer.write(table);
  writer.finish();
}

}  // namespace pointfair::io
