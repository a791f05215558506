// EPSG codes to LAS coordinate system records through PROJ (when built with it).
#include "crs_lookup.hpp"

#include <charconv>
#include <memory>
#include <string>

#include "arguments.hpp"

#ifdef POINTFAIR_HAVE_PROJ
#include <proj.h>
#endif

namespace pointfair::cli {

namespace {

// GeoTIFF key ids (GeoTIFF 1.0, section 6.3): the model, the raster type, and the codes.
constexpr std::uint16_t kModelType = 1024, kRasterType = 1025, kGeographicType = 2048, kProjectedType = 3072,
                        kVerticalType = 4096;

// The codes of "EPSG:N" or "EPSG:N+M" (M 0 when absent); false when it is not such a text.
bool parse_epsg(std::string_view text, int& horizontal, int& vertical) {
  constexpr std::string_view prefix = "EPSG:";
  if (text.size() <= prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i) {
    if (std::toupper(static_cast<unsigned char>(text[i])) != prefix[i]) return false;
  }
  text.remove_prefix(prefix.size());
  const std::size_t plus = text.find('+');
  auto number = [](std::string_view digits, int& code) {
    const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), code);
    return error == std::errc{} && end == digits.data() + digits.size() && code > 0;
  };
  vertical = 0;
  if (plus == std::string_view::npos) return number(text, horizontal);
  return number(text.substr(0, plus), horizontal) && number(text.substr(plus + 1), vertical);
}

#ifdef POINTFAIR_HAVE_PROJ
struct ContextDeleter {
  void operator()(PJ_CONTEXT* context) const { proj_context_destroy(context); }
};
struct ObjectDeleter {
  void operator()(PJ* object) const { proj_destroy(object); }
};
using Context = std::unique_ptr<PJ_CONTEXT, ContextDeleter>;
using Object = std::unique_ptr<PJ, ObjectDeleter>;

// The EPSG code of a system as PROJ identifies it; 0 when it has none.
std::uint16_t epsg_code(const PJ* crs) {
  const char* authority = proj_get_id_auth_name(crs, 0);
  const char* code = proj_get_id_code(crs, 0);
  if (authority == nullptr || code == nullptr || std::string_view(authority) != "EPSG") return 0;
  int value = 0;
  const std::string_view digits(code);
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  return error == std::errc{} && end == digits.data() + digits.size() && value > 0 && value <= 65535
             ? static_cast<std::uint16_t>(value)
             : 0;
}

// The model and code keys of a horizontal system; false for one GeoTIFF cannot name.
bool add_horizontal_keys(const PJ* crs, io::LasCoordinateSystem& out) {
  const std::uint16_t code = epsg_code(crs);
  if (code == 0) return false;
  switch (proj_get_type(crs)) {
    case PJ_TYPE_PROJECTED_CRS:
      out.geo_keys.insert(out.geo_keys.end(), {{kModelType, 1}, {kRasterType, 1}, {kProjectedType, code}});
      return true;
    case PJ_TYPE_GEOGRAPHIC_2D_CRS:
    case PJ_TYPE_GEOGRAPHIC_3D_CRS:
      out.geo_keys.insert(out.geo_keys.end(), {{kModelType, 2}, {kRasterType, 1}, {kGeographicType, code}});
      return true;
    default: return false;
  }
}
#endif

}  // namespace

io::LasCoordinateSystem lookup_crs(std::string_view text) {
  int horizontal = 0, vertical = 0;
  if (!parse_epsg(text, horizontal, vertical)) {
    throw UsageError("--crs must be EPSG:N or EPSG:N+M (a horizontal and a vertical system), got '" +
                     std::string(text) + "'");
  }
#ifdef POINTFAIR_HAVE_PROJ
  const Context context(proj_context_create());
  proj_log_level(context.get(), PJ_LOG_NONE);
  std::string name = "EPSG:";
  name += std::to_string(horizontal);
  if (vertical != 0) {
    name += '+';
    name += std::to_string(vertical);
  }
  const Object crs(proj_create(context.get(), name.c_str()));
  if (!crs || !proj_is_crs(crs.get())) {
    throw UsageError("--crs: " + name + " is not a coordinate system in PROJ's database");
  }
  io::LasCoordinateSystem out;
  const char* options[] = {"MULTILINE=NO", nullptr};
  const char* wkt = proj_as_wkt(context.get(), crs.get(), PJ_WKT1_GDAL, options);
  if (wkt == nullptr) throw UsageError("--crs: PROJ cannot write " + name + " as WKT");
  out.wkt = wkt;
  bool keys = false;
  if (proj_get_type(crs.get()) == PJ_TYPE_COMPOUND_CRS) {
    const Object horizontal_crs(proj_crs_get_sub_crs(context.get(), crs.get(), 0));
    const Object vertical_crs(proj_crs_get_sub_crs(context.get(), crs.get(), 1));
    const std::uint16_t vertical_code = vertical_crs ? epsg_code(vertical_crs.get()) : 0;
    keys = horizontal_crs && vertical_code != 0 && add_horizontal_keys(horizontal_crs.get(), out);
    if (keys) out.geo_keys.push_back({kVerticalType, vertical_code});
  } else {
    keys = add_horizontal_keys(crs.get(), out);
  }
  if (!keys) out.geo_keys.clear();  // only a LAS 1.4 file of formats 6-10 (WKT) can hold it
  return out;
#else
  throw UsageError("--crs needs PROJ, which this build of pointfair was made without (Debian: libproj-dev)");
#endif
}

}  // namespace pointfair::cli
