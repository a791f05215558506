// Non-finite and out-of-range values in attribute columns, through every reader, and the
// attributes the method computes. The rule (docs/hostile-inputs.md): every value read is finite
// and representable in its column's type, else a read error naming the file and the line (text)
// or the point (binary); no file written holds a value no reader would accept; computed
// attributes are never NaN.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "pointfair/io/point_file.hpp"
#include "scratch_folder.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/hdf5_file.hpp"

namespace fs = std::filesystem;
using namespace pointfair;

namespace {

class HostileValues : public testing_hardening::ScratchFolder {
 protected:
  static std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  static io::PointTable three_points(io::ScalarType type) {
    io::PointTable t;
    t.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
    t.attributes.push_back({"quality", type, {1.0, 12345.0, 3.0}});
    return t;
  }
};

void expect_error(const std::string& error, const std::string& a, const std::string& b) {
  EXPECT_NE(error.find(a), std::string::npos) << error;
  EXPECT_NE(error.find(b), std::string::npos) << error;
}

TEST_F(HostileValues, TextAttributesMustBeFiniteAndRepresentable) {
  // XYZ/CSV: every column is a double.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"nan", "is not a finite number"},          {"-inf", "is not a finite number"},
      {"Infinity", "is not a finite number"},     {"1e400", "is beyond the range of double"},
      {"-1e999", "is beyond the range of double"}, {"1e-400", "underflows to zero in double"},
  };
  for (const auto& [value, problem] : cases) {
    SCOPED_TRACE(value);
    const fs::path xyz = write_bytes("a.xyz", "x y z intensity\n0 0 0 1\n1 0 0 " + value + "\n0 1 0 2\n");
    expect_error(read_error(xyz), "a.xyz: line 3: '" + value + "' (column 4)", problem);
  }
  // A coordinate that underflows is not read as 0 either.
  expect_error(read_error(write_bytes("c.xyz", "0 0 0\n1e-400 0 0\n0 1 0\n")), "c.xyz: line 2: '1e-400'",
               "underflows to zero");
  // A value that is merely small (a subnormal double, zero written as such) reads.
  EXPECT_EQ(read_error(write_bytes("ok.xyz", "x y z a\n0 0 0 1e-310\n1 0 0 0.000\n0 1 0 -0e5\n")), "");
  // ASCII PLY: the property's own type.
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "property float intensity\nproperty double quality\nend_header\n";
  expect_error(read_error(write_bytes("f.ply", header + "0 0 0 1 1\n1 0 0 1e39 1\n")),
               "f.ply: line 11: '1e39' (property 'intensity')", "is beyond the range of float");
  expect_error(read_error(write_bytes("u.ply", header + "0 0 0 1e-50 1\n1 0 0 1 1\n")),
               "u.ply: line 10: '1e-50' (property 'intensity')", "underflows to zero in float");
  expect_error(read_error(write_bytes("n.ply", header + "0 0 0 1 nan\n1 0 0 1 1\n")),
               "n.ply: line 10: 'nan' (property 'quality')", "is not a finite number");
  EXPECT_EQ(read_error(write_bytes("g.ply", header + "0 0 0 1e-40 1e-300\n1 0 0 3e38 1e300\n")), "");
}

TEST_F(HostileValues, BinaryAttributesMustBeFinite) {
  // Written with a finite marker value, which is then replaced by NaN or inf in the bytes.
  const float marker = 12345.0f;
  for (const std::string name : {"a.ply", "a.las"}) {
    for (const float bad : {std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::infinity()}) {
      SCOPED_TRACE(name + " " + std::to_string(bad));
      const fs::path p = dir_ / name;
      io::write_points(p, three_points(io::ScalarType::Float32));
      std::string bytes = slurp(p);
      // As float, or as double where the format stores the column so.
      char pattern[8];
      std::memcpy(pattern, &marker, 4);
      std::size_t at = bytes.find(std::string(pattern, 4));
      if (at != std::string::npos) {
        std::memcpy(bytes.data() + at, &bad, 4);
      } else {
        const double wide = marker, wide_bad = bad;
        std::memcpy(pattern, &wide, 8);
        at = bytes.find(std::string(pattern, 8));
        ASSERT_NE(at, std::string::npos);
        std::memcpy(bytes.data() + at, &wide_bad, 8);
      }
      write_bytes(name, bytes);
      expect_error(read_error(p), name + ": ", " 1 has a non-finite value");
    }
  }
}

TEST_F(HostileValues, ContainerAttributesMustBeFinite) {
  const fs::path scan = dir_ / "scan.h5";
  tiles::write_container(scan, three_points(io::ScalarType::Float64));
  {
    auto f = tiles::h5::File::open(scan, true);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    auto d = f.dataset(std::string(tiles::layout::attributes) + "/quality");
    d.write_rows(1, 1, &nan);
    f.flush();
  }
  try {
    tiles::read_container(scan);
    ADD_FAILURE() << "a NaN attribute was read";
  } catch (const io::IoError& e) {
    expect_error(e.what(), "scan.h5", "/points/attributes/quality");
  }
}

TEST_F(HostileValues, WritersRefuseNonFiniteAttributes) {
  io::PointTable t = three_points(io::ScalarType::Float32);
  t.attributes[0].values[2] = std::numeric_limits<double>::infinity();
  for (const std::string name : {"w.ply", "w.xyz", "w.csv", "w.las"}) {
    SCOPED_TRACE(name);
    try {
      io::write_points(dir_ / name, t);
      ADD_FAILURE() << "written";
    } catch (const io::IoError& e) {
      expect_error(e.what(), name + ": point 2", "non-finite value (inf) in attribute 'quality'");
    }
    EXPECT_FALSE(fs::exists(dir_ / name));
  }
}

TEST_F(HostileValues, ComputedAttributesAreNeverNaNAtTheEdgeOfTheParameters) {
  std::vector<Vec3> points = sample_sphere(800, 1.0, 5).points;
  add_noise(points, 0.01, 6);
  for (const double floor : {1e-310, std::numeric_limits<double>::denorm_min(), 1e-300, 1.0}) {
    SCOPED_TRACE(floor);
    SmoothParams params;
    params.steps = 2;
    params.flow.weingarten.density_floor = floor;
    std::vector<Vec3> out = points;
    const SmoothReport report = smooth(out, params);
    for (const Vec3& p : out) ASSERT_TRUE(p.allFinite());
    const PointAttributes a = compute_attributes(out, report.neighborhoods, params.flow, report.lambda);
    for (std::size_t i = 0; i < out.size(); ++i) {
      ASSERT_TRUE(std::isfinite(a.k1[i]) && std::isfinite(a.k2[i]) && std::isfinite(a.mean_curvature[i]) &&
                  std::isfinite(a.laplacian_norm[i]) && a.d1[i].allFinite() && a.d2[i].allFinite() &&
                  a.normal[i].allFinite())
          << "point " << i;
    }
  }
}

}  // namespace
