#pragma once
// --crs EPSG:N (or EPSG:N+M, a horizontal and a vertical system) as LAS stores it, from
// PROJ's database (proj.db of Debian's proj-data).
#include <string_view>

#include "pointfair/io/las.hpp"

namespace pointfair::cli {

/// The WKT (version 1, as GDAL writes it) and GeoTIFF keys of `text`: GTModelType 1
/// (projected) with ProjectedCSType, or 2 (geographic) with GeographicType, GTRasterType 1,
/// and VerticalCSType for the vertical part of a compound system. Throws UsageError for a
/// text that is not EPSG:N or EPSG:N+M, a code PROJ does not know, or a build without PROJ.
io::LasCoordinateSystem lookup_crs(std::string_view text);

}  // namespace pointfair::cli
