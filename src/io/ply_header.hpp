#pragma once
// Internal: the parsed header of a PLY file.
#include <cstdint>
#include <string>
#include <vector>

#include "file_reader.hpp"
#include "pointfair/io/ply.hpp"
#include "pointfair/io/point_table.hpp"

namespace pointfair::io::detail {

struct PlyProperty {
  std::string name;
  ScalarType type = ScalarType::Float32;  // item type for a list
  bool is_list = false;
  ScalarType count_type = ScalarType::UInt8;  // lists only
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::Ascii;
  std::vector<PlyElement> elements;
  /// "comment ..." and "obj_info ..." lines, as written (without the line end).
  std::vector<std::string> header_lines;
};

/// Reads lines up to and including "end_header". Throws IoError on any malformed header.
PlyHeader read_ply_header(FileReader& reader);

/// "vertices" / "faces" / "edges": the plural of an element name for messages.
std::string plural_of(const std::string& element_name);

}  // namespace pointfair::io::detail
