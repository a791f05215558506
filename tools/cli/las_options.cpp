// The LAS output options of smooth, curvature, generate and export.
#include "las_options.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "crs_lookup.hpp"
#include "pointfair/io/point_file.hpp"

namespace pointfair::cli {

namespace {

// "a" (the same on x, y, z) or "a,b,c".
Vec3 parse_triple(std::string_view text, std::string_view what) {
  std::vector<double> values;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    values.push_back(parse_double(text.substr(start, comma - start), what));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (values.size() == 1) return Vec3::Constant(values[0]);
  if (values.size() != 3) throw UsageError(std::string(what) + " takes one number or three (x,y,z), got '" + std::string(text) + "'");
  return {values[0], values[1], values[2]};
}

}  // namespace

void add_las_options(ArgumentParser& p, io::LasWriteOptions& o) {
  const OptionGroup before = p.current_group();
  p.group(OptionGroup::Advanced);
  p.value("las-version", "1.2|1.4",
          "LAS output: the version. 1.2 (point formats 0-3) is read by every LAS reader; 1.4 "
          "(formats 6-10) holds 256 classes, 15 returns and described extra bytes. Default: a LAS "
          "input's own; from other formats 1.2 when the attributes fit its fields, else 1.4.",
          [&o](std::string_view v) {
            if (v == "1.2") o.version_minor = 2;
            else if (v == "1.4") o.version_minor = 4;
            else throw UsageError("--las-version must be 1.2 or 1.4, got '" + std::string(v) + "'");
          });
  p.value("scale", "S|SX,SY,SZ",
          "LAS output: the length of one step of the stored integers (e.g. 0.001: millimetres "
          "for metres). Default: a LAS input's own; else the largest power of ten with a million "
          "steps across the largest extent, at most 0.001.",
          [&o](std::string_view v) {
            const Vec3 scale = parse_triple(v, "--scale");
            for (int a = 0; a < 3; ++a) {
              if (!(scale[a] > 0 && std::isfinite(scale[a]))) throw UsageError("--scale must be positive and finite");
            }
            o.scale = scale;
          });
  p.value("offset", "O|OX,OY,OZ",
          "LAS output: the position of the stored integer 0. Default: a LAS input's own; else "
          "the lower corner of the bounds, rounded down to whole units.",
          [&o](std::string_view v) {
            const Vec3 offset = parse_triple(v, "--offset");
            if (!offset.allFinite()) throw UsageError("--offset must be finite");
            o.offset = offset;
          });
  p.value("crs", "EPSG:N[+M]",
          "LAS output: the coordinate system, replacing a LAS input's (the points are not "
          "transformed; as PDAL's a_srs). EPSG:N+M adds a vertical system. Written as OGC WKT in "
          "LAS 1.4 formats 6-10, else as GeoTIFF keys. Default: a LAS input's own; none.",
          [&o](std::string_view v) { o.crs = lookup_crs(v); });
  p.group(before);
}

void require_las_output(const io::LasWriteOptions& o, const std::filesystem::path& output) {
  if (o.version_minor == 0 && !o.scale && !o.offset && !o.crs) return;
  if (io::point_format_of(output) != io::PointFormat::Las) {
    throw UsageError("--las-version, --scale, --offset and --crs apply to a LAS output (.las or .laz), not '" +
                     output.string() + "'");
  }
}

}  // namespace pointfair::cli
