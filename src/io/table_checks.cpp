#include "table_checks.hpp"

#include <cmath>
#include <string>

#include "io_error.hpp"
#include "number_text.hpp"

namespace pointfair::io::detail {

void check_table(const std::filesystem::path& file, const PointTable& table) {
  for (const Attribute& attribute : table.attributes) {
    if (attribute.values.size() != table.size()) {
      fail(file, "attribute '" + attribute.name + "' has " +
                     std::to_string(attribute.values.size()) + " values for " +
                     std::to_string(table.size()) + " points");
    }
  }
  check_finite(file, table.positions, 0, table.size(), "point");
}

void check_finite(const std::filesystem::path& file, const std::vector<Vec3>& positions,
                  std::size_t first, std::size_t last, std::string_view noun,
                  std::string_view suffix) {
  for (std::size_t i = first; i < last; ++i) {
    for (int c = 0; c < 3; ++c) {
      const double value = positions[i][c];
      if (!std::isfinite(value)) {
        fail(file, std::string(noun) + " " + std::to_string(i) + " has a non-finite coordinate (" +
                       std::string(non_finite_name(value)) + ")" + std::string(suffix));
      }
    }
  }
}

}  // namespace pointfair::io::detail
