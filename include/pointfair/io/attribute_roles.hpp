#pragma once
// What some attributes of a point table mean, by their names: normals, colours and the
// classification. The commands use it to refresh normals after the points moved, to leave a
// cloud's own colours alone and to smooth only some classes.
#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "pointfair/io/point_table.hpp"

namespace pointfair::io {

/// The attributes of `table` that hold a normal, as index triplets (x, y, z components) into
/// table.attributes: nx ny nz, normal_x normal_y normal_z, normalx normaly normalz, n_x n_y
/// n_z, matched case-insensitively, of a float type (integer "normals" are left alone). None for a text table without a header line, whose
/// column names are guesses (a headerless 6-column file's "nx ny nz" may well be colours).
std::vector<std::array<std::size_t, 3>> normal_columns(const PointTable& table);

/// Overwrites every normal triplet of normal_columns(table) with `normals` (one per point),
/// each flipped where it points against the old normal so that the source's orientation
/// convention (e.g. towards the scanner) is kept; the columns keep their types.
/// Requires normals.size() == table.size().
void refresh_normals(PointTable& table, std::span<const Vec3> normals);

/// The attribute holding a LAS classification code: "classification" (a LAS file's field, a
/// PLY property or a text column of that name) or "class", case-insensitively; nullptr when
/// there is none, and for a text table without a header line (its names are guesses).
const Attribute* classification_column(const PointTable& table);

/// True if `table` has colour columns: red green blue or r g b (case-insensitive).
bool has_colour(const PointTable& table);

}  // namespace pointfair::io
