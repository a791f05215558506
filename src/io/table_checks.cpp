#include "table_checks.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "io_error.hpp"
#include "number_text.hpp"

namespace pointfair::io::detail {

void check_table(const std::filesystem::path& file, const PointTable& table, std::uint64_t first) {
  for (const Attribute& attribute : table.attributes) {
    if (attribute.values.size() != table.size()) {
      fail(file, "attribute '" + attribute.name + "' has " +
                     std::to_string(attribute.values.size()) + " values for " +
                     std::to_string(table.size()) + " points");
    }
  }
  for (std::size_t i = 0; i < table.size(); ++i) check_finite_point(file, table.positions[i], first + i, "point");
  // No file written holds a value no reader would accept, nor a value its column's type turns
  // into another (a double beyond float's range in a float column would be written as inf).
  check_attribute_values(file, table, 0, first, "point");
  for (const Attribute& a : table.attributes) {
    if (a.type != ScalarType::Float32) continue;
    for (std::size_t i = 0; i < a.values.size(); ++i)
      if (std::abs(a.values[i]) > static_cast<double>(std::numeric_limits<float>::max()))
        fail(file, "point " + std::to_string(first + i) + ": value " + std::to_string(a.values[i]) +
                       " of attribute '" + a.name + "' is beyond the range of its type, float");
  }
}

void require_schema(const std::filesystem::path& file, const PointTable& schema, const PointTable& chunk) {
  bool same = chunk.attributes.size() == schema.attributes.size();
  for (std::size_t a = 0; same && a < chunk.attributes.size(); ++a) {
    same = chunk.attributes[a].name == schema.attributes[a].name &&
           chunk.attributes[a].type == schema.attributes[a].type;
  }
  if (!same) fail(file, "a chunk's attributes differ from those the file was opened with");
}

namespace {

bool has_nonzero_digit(std::string_view token) {
  for (const char c : token) {
    if (c == 'e' || c == 'E') break;
    if (c >= '1' && c <= '9') return true;
  }
  return false;
}

bool is_digits(std::string_view token) {
  // A number written with digits (not "nan", "inf", "infinity").
  for (const char c : token)
    if (c >= '0' && c <= '9') return true;
  return false;
}

}  // namespace

void check_text_value(const std::filesystem::path& file, std::string_view where, std::string_view token,
                      double value, ScalarType type, std::string_view what, bool only_underflow) {
  const std::string type_name = type == ScalarType::Float32 ? "float" : "double";
  const std::string quoted = std::string(where) + "'" + std::string(token) + "' (" + std::string(what) + ")";
  if (!std::isfinite(value)) {
    if (only_underflow) return;
    if (is_digits(token)) fail(file, quoted + " is beyond the range of " + type_name);
    fail(file, quoted + " is not a finite number");
  }
  if (value == 0 && has_nonzero_digit(token)) fail(file, quoted + " underflows to zero in " + type_name);
}

void check_attribute_values(const std::filesystem::path& file, const PointTable& table, std::size_t from,
                            std::uint64_t first_index, std::string_view noun) {
  for (const Attribute& a : table.attributes) {
    if (a.type != ScalarType::Float32 && a.type != ScalarType::Float64) continue;
    for (std::size_t i = from; i < a.values.size(); ++i) {
      if (!std::isfinite(a.values[i]))
        fail(file, std::string(noun) + " " + std::to_string(first_index + (i - from)) + " has a non-finite value (" +
                       std::string(non_finite_name(a.values[i])) + ") in attribute '" + a.name + "'");
    }
  }
}

void check_finite(const std::filesystem::path& file, const std::vector<Vec3>& positions,
                  std::size_t first, std::size_t last, std::string_view noun,
                  std::string_view suffix) {
  for (std::size_t i = first; i < last; ++i) check_finite_point(file, positions[i], i, noun, suffix);
}

void check_finite_point(const std::filesystem::path& file, const Vec3& position, std::uint64_t index,
                        std::string_view noun, std::string_view suffix) {
  for (int c = 0; c < 3; ++c) {
    const double value = position[c];
    if (!std::isfinite(value)) {
      fail(file, std::string(noun) + " " + std::to_string(index) + " has a non-finite coordinate (" +
                     std::string(non_finite_name(value)) + ")" + std::string(suffix));
    }
  }
}

}  // namespace pointfair::io::detail
