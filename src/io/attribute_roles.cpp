#include "pointfair/io/attribute_roles.hpp"

#include <cassert>
#include <cctype>
#include <string>
#include <string_view>

namespace pointfair::io {

namespace {

bool same_name(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i]))) return false;
  }
  return true;
}

// The index of the attribute called `name` (case-insensitive), or npos.
std::size_t index_of(const PointTable& table, std::string_view name) {
  for (std::size_t a = 0; a < table.attributes.size(); ++a) {
    if (same_name(table.attributes[a].name, name)) return a;
  }
  return static_cast<std::size_t>(-1);
}

bool is_float(ScalarType type) { return type == ScalarType::Float32 || type == ScalarType::Float64; }

}  // namespace

std::vector<std::array<std::size_t, 3>> normal_columns(const PointTable& table) {
  std::vector<std::array<std::size_t, 3>> found;
  if (table.text && !table.text->header) return found;
  constexpr std::array<std::array<std::string_view, 3>, 4> kNames{{{"nx", "ny", "nz"},
                                                                    {"normal_x", "normal_y", "normal_z"},
                                                                    {"normalx", "normaly", "normalz"},
                                                                    {"n_x", "n_y", "n_z"}}};
  constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  for (const auto& names : kNames) {
    std::array<std::size_t, 3> triplet{};
    bool complete = true;
    for (std::size_t c = 0; c < 3; ++c) {
      triplet[c] = index_of(table, names[c]);
      complete = complete && triplet[c] != kNone && is_float(table.attributes[triplet[c]].type);
    }
    if (complete) found.push_back(triplet);
  }
  return found;
}

void refresh_normals(PointTable& table, std::span<const Vec3> normals) {
  assert(normals.size() == table.size());
  for (const auto& triplet : normal_columns(table)) {
    std::array<Attribute*, 3> column{};
    for (std::size_t c = 0; c < 3; ++c) column[c] = &table.attributes[triplet[c]];
    for (std::size_t i = 0; i < table.size(); ++i) {
      const Vec3 old(column[0]->values[i], column[1]->values[i], column[2]->values[i]);
      const double sign = old.dot(normals[i]) < 0.0 ? -1.0 : 1.0;
      for (std::size_t c = 0; c < 3; ++c) {
        column[c]->values[i] = sign * normals[i][static_cast<Eigen::Index>(c)];
      }
    }
  }
}

const Attribute* classification_column(const PointTable& table) {
  if (table.text && !table.text->header) return nullptr;
  for (const std::string_view name : {"classification", "class"}) {
    const std::size_t a = index_of(table, name);
    if (a != static_cast<std::size_t>(-1)) return &table.attributes[a];
  }
  return nullptr;
}

bool has_colour(const PointTable& table) {
  constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  const auto all = [&](std::string_view r, std::string_view g, std::string_view b) {
    return index_of(table, r) != kNone && index_of(table, g) != kNone && index_of(table, b) != kNone;
  };
  return all("red", "green", "blue") || all("r", "g", "b");
}

}  // namespace pointfair::io
