#pragma once
// The coordinate system a LAS file declares, as one line of text for `pointfair info`.
#include <string>

#include "pointfair/io/point_table.hpp"

namespace pointfair::cli {

/// From the LASF_Projection records: an OGC WKT record (2112) gives its EPSG code (the last
/// AUTHORITY["EPSG",N] or ID["EPSG",N], which belongs to the outermost system; EPSG:N+M for a
/// compound system without a code of its own) and its name;
/// a GeoTIFF key directory (34735) its projected (3072) or geographic (2048) EPSG code and
/// vertical one (4096). "none" when there is neither.
std::string crs_of(const io::LasMetadata& las);

}  // namespace pointfair::cli
