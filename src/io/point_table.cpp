#include "pointfair/io/point_table.hpp"

#include <utility>

namespace pointfair::io {

std::size_t scalar_size(ScalarType type) {
  switch (type) {
    case ScalarType::Int8:
    case ScalarType::UInt8:
      return 1;
    case ScalarType::Int16:
    case ScalarType::UInt16:
      return 2;
    case ScalarType::Int32:
    case ScalarType::UInt32:
    case ScalarType::Float32:
      return 4;
    case ScalarType::Float64:
      return 8;
  }
  return 8;  // unreachable for valid enumerators
}

std::string_view scalar_name(ScalarType type) {
  switch (type) {
    case ScalarType::Int8:
      return "char";
    case ScalarType::UInt8:
      return "uchar";
    case ScalarType::Int16:
      return "short";
    case ScalarType::UInt16:
      return "ushort";
    case ScalarType::Int32:
      return "int";
    case ScalarType::UInt32:
      return "uint";
    case ScalarType::Float32:
      return "float";
    case ScalarType::Float64:
      return "double";
  }
  return "double";  // unreachable for valid enumerators
}

const Attribute* PointTable::find(std::string_view name) const {
  for (const Attribute& attribute : attributes) {
    if (attribute.name == name) return &attribute;
  }
  return nullptr;
}

Attribute* PointTable::find(std::string_view name) {
  for (Attribute& attribute : attributes) {
    if (attribute.name == name) return &attribute;
  }
  return nullptr;
}

Attribute& PointTable::set(std::string name, ScalarType type, std::vector<double> values) {
  if (Attribute* existing = find(name)) {
    existing->type = type;
    existing->values = std::move(values);
    return *existing;
  }
  attributes.push_back(Attribute{std::move(name), type, std::move(values)});
  return attributes.back();
}

}  // namespace pointfair::io
