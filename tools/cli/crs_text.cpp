#include "crs_text.hpp"

#include <cstdint>
#include <string_view>

namespace pointfair::cli {
namespace {

// The number after the last "<key>[\"EPSG\"," in `wkt` (WKT1's AUTHORITY, WKT2's ID), or empty.
std::string last_epsg(std::string_view wkt, std::string_view key) {
  const std::string pattern = std::string(key) + "[\"EPSG\",";
  const std::size_t at = wkt.rfind(pattern);
  if (at == std::string_view::npos) return {};
  std::string code;
  for (std::size_t i = at + pattern.size(); i < wkt.size(); ++i) {
    const char c = wkt[i];
    if (c >= '0' && c <= '9') code += c;
    else if (c != '"' && c != ' ') break;
  }
  return code;
}

// The first quoted text of the WKT: the outermost system's name.
std::string wkt_name(std::string_view wkt) {
  const std::size_t open = wkt.find('"');
  if (open == std::string_view::npos) return {};
  const std::size_t close = wkt.find('"', open + 1);
  if (close == std::string_view::npos) return {};
  return std::string(wkt.substr(open + 1, close - open - 1));
}

// The EPSG code of the last AUTHORITY (WKT1) or ID (WKT2) in `wkt`, or empty.
std::string last_code(std::string_view wkt) {
  const std::string code = last_epsg(wkt, "AUTHORITY");
  return code.empty() ? last_epsg(wkt, "ID") : code;
}

// The text after the bracket that closes the one opened at `open` (quotes skipped); empty
// when it is not closed.
std::string_view after_closing(std::string_view wkt, std::size_t open) {
  int depth = 0;
  bool quoted = false;
  for (std::size_t i = open; i < wkt.size(); ++i) {
    const char c = wkt[i];
    if (c == '"') quoted = !quoted;
    if (quoted) continue;
    if (c == '[' || c == '(') ++depth;
    if ((c == ']' || c == ')') && --depth == 0) return wkt.substr(i + 1);
  }
  return {};
}

// A compound system without a code of its own (EPSG:N+M, as PROJ writes it): the
// horizontal code (the last before the vertical system) and the vertical one. Empty when
// `wkt` is not such a system.
std::string compound_codes(std::string_view wkt) {
  if (!wkt.starts_with("COMPD_CS") && !wkt.starts_with("COMPOUNDCRS")) return {};
  std::size_t vertical = wkt.find("VERT_CS[");
  if (vertical == std::string_view::npos) vertical = wkt.find("VERTCRS[");
  if (vertical == std::string_view::npos) return {};
  const std::string_view rest = after_closing(wkt, wkt.find('[', vertical));
  if (!last_code(rest).empty()) return {};  // the compound has a code of its own
  const std::string horizontal = last_code(wkt.substr(0, vertical));
  const std::string height = last_code(wkt.substr(0, wkt.size() - rest.size()));
  if (horizontal.empty() || height.empty()) return {};
  return "EPSG:" + horizontal + "+" + height;
}

std::string from_wkt(std::string_view wkt) {
  while (!wkt.empty() && wkt.back() == '\0') wkt.remove_suffix(1);
  const std::string code = last_code(wkt);
  const std::string name = wkt_name(wkt);
  std::string text = compound_codes(wkt);
  if (text.empty()) text = code.empty() ? "no EPSG code" : "EPSG:" + code;
  if (!name.empty()) text += " \"" + name + "\"";
  return text + " (OGC WKT)";
}

std::string from_geokeys(std::string_view data) {
  const auto word = [&](std::size_t i) {
    return static_cast<std::uint16_t>(static_cast<unsigned char>(data[2 * i]) |
                                      (static_cast<unsigned char>(data[2 * i + 1]) << 8));
  };
  const std::size_t words = data.size() / 2;
  if (words < 4) return "GeoTIFF keys (unreadable: too short)";
  const std::size_t keys = word(3);
  std::string horizontal, vertical;
  for (std::size_t k = 0; k < keys && 4 + 4 * k + 3 < words; ++k) {
    const std::size_t e = 4 + 4 * k;
    const std::uint16_t id = word(e), location = word(e + 1), value = word(e + 3);
    if (location != 0) continue;
    const std::string code = value == 32767 ? "user-defined" : "EPSG:" + std::to_string(value);
    if (id == 3072 || (id == 2048 && horizontal.empty())) horizontal = code;
    if (id == 4096) vertical = code;
  }
  std::string text = horizontal.empty() ? "no EPSG code" : horizontal;
  if (!vertical.empty()) text += " + vertical " + vertical;
  return text + " (GeoTIFF keys)";
}

}  // namespace

std::string crs_of(const io::LasMetadata& las) {
  for (const io::LasRecord& r : las.records)
    if (r.user_id == "LASF_Projection" && r.record_id == 2112) return from_wkt(r.data);
  for (const io::LasRecord& r : las.records)
    if (r.user_id == "LASF_Projection" && r.record_id == 34735) return from_geokeys(r.data);
  return "none";
}

}  // namespace pointfair::cli
