#pragma once
// Text point files (.xyz, .txt, .pts, .csv, .asc): one point per line.
#include <cstdint>
#include <filesystem>
#include <memory>

#include "pointfair/io/point_chunks.hpp"
#include "pointfair/io/point_table.hpp"

namespace pointfair::io {

/// Reads a text point file. Values are separated by whitespace, commas or semicolons; blank
/// lines and lines starting with '#' are skipped. If a token of the first remaining line is
/// not a number, that line is a header naming the columns (x, y, z required, matched
/// case-insensitively; other names kept as written). A header starting with "//" is
/// CloudCompare's (its ASCII export: "//X Y Z R G B Nx Ny Nz ..."): R G B A and Nx Ny Nz are
/// read as red green blue alpha and nx ny nz. Without a header the columns are
/// x y z, then nx ny nz when there are exactly 6 columns, otherwise extras named
/// "field_<column>" (0-based, so the fourth column is "field_3"). A first line holding a
/// single integer (a point count, as in many .pts files) is skipped. Every attribute is
/// Float64 and position_type is Float64.
/// Throws IoError "<file>: <problem>" for an empty file, a row whose column count differs
/// from the first ("line 17: expected 4 columns, found 3"), a value that is not a number,
/// a non-finite coordinate ("line 9: non-finite coordinate (nan)"), or a header without x,
/// y or z.
PointTable read_xyz(const std::filesystem::path& file, const ReadOptions& options = {});

/// read_xyz a chunk at a time: the reader opens by reading up to the first row (the schema
/// depends on it); count() is nullopt (a text file declares none it must keep). Same errors
/// and warnings.
std::unique_ptr<PointChunkReader> open_xyz_reader(const std::filesystem::path& file,
                                                  const ReadOptions& options = {});

/// Writes `table` atomically as text: a header line "x y z <attribute names...>" when there
/// are attributes, then one line per point with the shortest decimal text that reads back
/// as the same double. Values are separated by ',' for a .csv file and by ' ' otherwise. A
/// .asc file gets CloudCompare's header ("//X Y Z R G B Nx Ny Nz <other names>") unless the
/// source has a header of its own.
/// Throws IoError "<file>: <problem>" for a non-finite position, an attribute whose size
/// differs from the number of points, a name that cannot be read back from the header
/// (empty, containing a separator or '#', duplicate, or x/y/z in any case) or a write failure.
void write_xyz(const std::filesystem::path& file, const PointTable& table);

/// write_xyz a chunk at a time, with the attributes of `schema` (its values are ignored).
/// Names are checked when it opens; `count` is only checked by finish().
std::unique_ptr<PointChunkWriter> open_xyz_writer(const std::filesystem::path& file,
                                                  const PointTable& schema, std::uint64_t count);

}  // namespace pointfair::io
