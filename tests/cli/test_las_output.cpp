// End-to-end: --las-version, --scale, --offset and --crs of a LAS output, read back by
// `pointfair info` and the LAS reader; in core and out of core alike; misuse refused.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hardening/cli_child.hpp"
#include "pointfair/io/las.hpp"

namespace pointfair::testing_cli {
namespace {

class CliLasOutputTest : public CliTest {
 protected:
  // A noisy sphere as text with an intensity column (every field fits LAS 1.2).
  fs::path write_text_cloud(std::size_t n) {
    io::PointTable t;
    t.positions = sample_sphere(n, 10.0, 3).points;
    add_noise(t.positions, 0.1, 4);
    std::vector<double> intensity(n);
    for (std::size_t i = 0; i < n; ++i) intensity[i] = static_cast<double>(i % 1000);
    t.set("intensity", io::ScalarType::UInt16, intensity);
    const fs::path p = dir_ / "cloud.xyz";
    io::write_points(p, t);
    return p;
  }
  Result smooth(const fs::path& in, const fs::path& out, std::vector<std::string> options) {
    std::vector<std::string> args{"smooth", in.string(), out.string(), "--steps", "2", "--quiet"};
    args.insert(args.end(), options.begin(), options.end());
    return run(args);
  }
};

TEST_F(CliLasOutputTest, VersionScaleAndOffsetAsGiven) {
  const fs::path in = write_text_cloud(3000);
  ASSERT_EQ(smooth(in, dir_ / "auto.las", {}).exit_code, 0);
  EXPECT_EQ(io::read_las(dir_ / "auto.las").las->version_minor, 2);  // intensity fits 1.2
  const Result r = smooth(in, dir_ / "a.las", {"--las-version", "1.4", "--scale", "0.01,0.01,0.001", "--offset", "5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::PointTable a = io::read_las(dir_ / "a.las");
  EXPECT_EQ(a.las->version_minor, 4);
  EXPECT_EQ(a.las->point_format, 6);
  EXPECT_EQ(a.quantization->scale, Vec3(0.01, 0.01, 0.001));
  EXPECT_EQ(a.quantization->offset, Vec3::Constant(5));
  EXPECT_EQ(a.find("intensity")->values, io::read_las(dir_ / "auto.las").find("intensity")->values);
}

#ifdef POINTFAIR_HAVE_PROJ
TEST_F(CliLasOutputTest, CrsFromAnEpsgCodeAsGeoKeysOrWkt) {
  const fs::path in = write_text_cloud(2000);
  ASSERT_EQ(smooth(in, dir_ / "keys.las", {"--crs", "EPSG:2056"}).exit_code, 0);
  Result info = run({"info", (dir_ / "keys.las").string(), "--json"});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("\"crs\": \"EPSG:2056 (GeoTIFF keys)\""), std::string::npos) << info.out;

  ASSERT_EQ(smooth(in, dir_ / "wkt.las", {"--crs", "epsg:2056+5728", "--las-version", "1.4"}).exit_code, 0);
  info = run({"info", (dir_ / "wkt.las").string(), "--json"});
  EXPECT_NE(info.out.find("\"crs\": \"EPSG:2056+5728 \\\"CH1903+ / LV95 + LN02 height\\\" (OGC WKT)\""),
            std::string::npos)
      << info.out;
  const io::PointTable wkt = io::read_las(dir_ / "wkt.las");
  EXPECT_NE(wkt.las->global_encoding & 16, 0);

  // A geographic system: GTModelType 2 with GeographicType 4326; a LAS input's system is replaced.
  ASSERT_EQ(smooth(dir_ / "keys.las", dir_ / "wgs.las", {"--crs", "EPSG:4326"}).exit_code, 0);
  info = run({"info", (dir_ / "wgs.las").string(), "--json"});
  EXPECT_NE(info.out.find("\"crs\": \"EPSG:4326 (GeoTIFF keys)\""), std::string::npos) << info.out;
  // Without --crs, a LAS input keeps its own.
  ASSERT_EQ(smooth(dir_ / "keys.las", dir_ / "kept.las", {}).exit_code, 0);
  info = run({"info", (dir_ / "kept.las").string(), "--json"});
  EXPECT_NE(info.out.find("\"crs\": \"EPSG:2056 (GeoTIFF keys)\""), std::string::npos) << info.out;
}
#endif

TEST_F(CliLasOutputTest, OutOfCoreWritesTheSameBytesAsInCore) {
  const fs::path in = write_text_cloud(8000);
  std::vector<std::string> options{"--las-version", "1.4", "--scale", "0.001", "--offset", "-20,-20,-20"};
#ifdef POINTFAIR_HAVE_PROJ
  options.insert(options.end(), {"--crs", "EPSG:32633"});
#endif
  ASSERT_EQ(smooth(in, dir_ / "core.las", options).exit_code, 0);
  options.insert(options.end(), {"--memory-budget", "2MiB", "--json"});
  const Result r = smooth(in, dir_ / "tiled.las", options);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"out_of_core\": true"), std::string::npos) << r.out;
  EXPECT_EQ(slurp(dir_ / "tiled.las"), slurp(dir_ / "core.las"));
}

TEST_F(CliLasOutputTest, MisuseIsRefusedBeforeAnyWork) {
  const fs::path in = write_text_cloud(500);
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases{
      {{"--las-version", "1.3"}, "--las-version must be 1.2 or 1.4"},
      {{"--scale", "0"}, "--scale must be positive"},
      {{"--scale", "0.1,0.1"}, "one number or three"},
      {{"--offset", "nan"}, "--offset"},
      {{"--crs", "UTM33"}, "EPSG:N"},
      {{"--crs", "EPSG:"}, "EPSG:N"},
  };
  for (const auto& [options, message] : cases) {
    const Result r = smooth(in, dir_ / "out.las", options);
    EXPECT_EQ(r.exit_code, 2) << options[0];
    EXPECT_NE(r.err.find(message), std::string::npos) << r.err;
  }
  // LAS options for another format.
  const Result ply = smooth(in, dir_ / "out.ply", {"--scale", "0.001"});
  EXPECT_EQ(ply.exit_code, 2);
  EXPECT_NE(ply.err.find("apply to a LAS output"), std::string::npos) << ply.err;
#ifdef POINTFAIR_HAVE_PROJ
  const Result unknown = smooth(in, dir_ / "out.las", {"--crs", "EPSG:1"});
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("EPSG:1 is not a coordinate system"), std::string::npos) << unknown.err;
#endif
  EXPECT_EQ(joined(other_files({"cloud.xyz"})), "");
}

}  // namespace
}  // namespace pointfair::testing_cli
