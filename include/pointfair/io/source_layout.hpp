#pragma once
// A table's text and PLY layouts (PointTable::text, PointTable::ply) as one string, so that
// a container can keep them between the import of a file and the export of the result.
#include <string>
#include <string_view>

#include "pointfair/io/point_table.hpp"

namespace pointfair::io {

/// table.text and table.ply as lines of space-separated, percent-escaped fields; empty when
/// the table has neither.
std::string encode_source_layout(const PointTable& table);

/// Sets table.text and table.ply from encode_source_layout's text. Returns false (and leaves
/// `table` unchanged) for text it did not write.
bool decode_source_layout(std::string_view encoded, PointTable& table);

}  // namespace pointfair::io
