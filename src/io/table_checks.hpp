#pragma once
// Internal checks shared by the writers, run before any output file is created.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>
#include <vector>

#include "pointfair/io/point_table.hpp"

namespace pointfair::io::detail {

/// Throws IoError "<file>: ..." if an attribute's size differs from the number of points or
/// a position is not finite (a file no reader, ours included, would accept).
/// `first` is the file index of the table's first point (for messages).
void check_table(const std::filesystem::path& file, const PointTable& table, std::uint64_t first = 0);

/// Throws IoError "<file>: ..." unless `chunk` has the attributes of `schema` (names and
/// types, in order): a chunk written to a streaming writer.
void require_schema(const std::filesystem::path& file, const PointTable& schema, const PointTable& chunk);

/// Throws IoError "<file>: <noun> <i> has a non-finite coordinate (nan)<suffix>" for the
/// first non-finite coordinate among positions[first, last).
void check_finite(const std::filesystem::path& file, const std::vector<Vec3>& positions,
                  std::size_t first, std::size_t last, std::string_view noun = "vertex",
                  std::string_view suffix = {});

/// Throws IoError "<file>: <noun> <index> has a non-finite coordinate (nan)<suffix>" if
/// `position` is not finite.
void check_finite_point(const std::filesystem::path& file, const Vec3& position, std::uint64_t index,
                        std::string_view noun = "vertex", std::string_view suffix = {});

/// The one rule for values read (docs/hostile-inputs.md): every value must be finite and
/// representable in its column's type. Throws IoError "<file>: <where>'<token>' (<what>) is
/// not a finite number" (nan, inf), "... is beyond the range of float" (a text value that
/// overflowed to inf), or "... underflows to zero in float" (a text value with a non-zero digit
/// read as 0). `value` is `token` parsed as `type`; `where` e.g. "line 5: ". With
/// `only_underflow`, non-finite values are left to another check (coordinates have their own).
void check_text_value(const std::filesystem::path& file, std::string_view where, std::string_view token,
                      double value, ScalarType type, std::string_view what, bool only_underflow = false);

/// Throws IoError "<file>: <noun> <index> has a non-finite value (nan) in attribute '<name>'"
/// for the first non-finite value of a float attribute in rows [from, table.size()); row
/// `from` is <noun> `first_index`.
void check_attribute_values(const std::filesystem::path& file, const PointTable& table, std::size_t from,
                            std::uint64_t first_index, std::string_view noun = "point");

}  // namespace pointfair::io::detail
