#include "table_checks.hpp"

#include <cmath>
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
}

void require_schema(const std::filesystem::path& file, const PointTable& schema, const PointTable& chunk) {
  bool same = chunk.attributes.size() == schema.attributes.size();
  for (std::size_t a = 0; same && a < chunk.attributes.size(); ++a) {
    same = chunk.attributes[a].name == schema.attributes[a].name &&
           chunk.attributes[a].type == schema.attributes[a].type;
  }
  if (!same) fail(file, "a chunk's attributes differ from those the file was opened with");
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
