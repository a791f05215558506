#pragma once
// Internal checks shared by the writers, run before any output file is created.
#include <cstddef>
#include <filesystem>
#include <string_view>
#include <vector>

#include "pointfair/io/point_table.hpp"

namespace pointfair::io::detail {

/// Throws IoError "<file>: ..." if an attribute's size differs from the number of points or
/// a position is not finite (a file no reader, ours included, would accept).
void check_table(const std::filesystem::path& file, const PointTable& table);

/// Throws IoError "<file>: <noun> <i> has a non-finite coordinate (nan)<suffix>" for the
/// first non-finite coordinate among positions[first, last).
void check_finite(const std::filesystem::path& file, const std::vector<Vec3>& positions,
                  std::size_t first, std::size_t last, std::string_view noun = "vertex",
                  std::string_view suffix = {});

}  // namespace pointfair::io::detail
