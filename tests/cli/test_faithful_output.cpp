// End-to-end: `pointfair smooth IN OUT` with no options changes the positions (and the
// normals, which it recomputes) and nothing else: every other attribute comes back bit for
// bit, in the file's own layout, in core and out of core.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "pointfair/io/las.hpp"
#include "pointfair/io/ply.hpp"
#include "pointfair/io/point_file.hpp"

namespace fs = std::filesystem;
using namespace pointfair;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> split(const std::string& line, char separator) {
  std::vector<std::string> fields;
  std::istringstream in(line);
  for (std::string field; std::getline(in, field, separator);) fields.push_back(field);
  return fields;
}

// A scan-like scene in UTM coordinates: a noisy ground plane and a box-shaped building, with
// colours, intensity and classification (2 ground, 6 building).
struct ScanPoint {
  double x, y, z;
  int red, green, blue, intensity, classification;
};

std::vector<ScanPoint> scan_scene(std::size_t n) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<ScanPoint> points;
  for (std::size_t i = 0; i < n; ++i) {
    ScanPoint p{};
    const double a = 40.0 * u(rng), b = 40.0 * u(rng);
    p.x = 500000.0 + a;
    p.y = 4200000.0 + b;
    const bool roof = i % 4 == 0;  // a quarter of the points on a 10 m roof
    p.x = roof ? 500015.0 + 10.0 * u(rng) : p.x;
    p.y = roof ? 4200015.0 + 10.0 * u(rng) : p.y;
    p.z = (roof ? 110.0 : 100.0) + noise(rng);
    p.classification = roof ? 6 : 2;
    p.red = static_cast<int>(i * 37 % 256);
    p.green = static_cast<int>(i * 101 % 256);
    p.blue = roof ? 200 : 30;
    p.intensity = static_cast<int>(i * 7919 % 65536);
    points.push_back(p);
  }
  return points;
}

// "%.3f" coordinates, as a scanner's export writes them.
std::string fixed3(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.3f", v);
  return buffer;
}

class FaithfulOutput : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = fs::temp_directory_path() / ("pointfair_faithful_" + std::to_string(rd()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Runs `pointfair ARGS`; returns the exit code, stderr in `err`.
  int run(const std::string& args, std::string* err = nullptr) {
    const fs::path e = dir_ / "stderr.txt";
    const std::string command =
        std::string(POINTFAIR_EXE) + " " + args + " >/dev/null 2>" + e.string() + " </dev/null";
    const int status = std::system(command.c_str());
    if (err != nullptr) *err = slurp(e);
    fs::remove(e);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  // smooth IN OUT with the defaults (a few steps to keep the test short), in core or, with a
  // memory budget below the cloud's, out of core.
  void smooth(const fs::path& in, const fs::path& out, bool out_of_core) {
    std::string err;
    const std::string budget = out_of_core ? " --memory-budget 8M" : "";
    ASSERT_EQ(run("smooth " + in.string() + " " + out.string() + " --steps 3 --quiet" + budget, &err), 0) << err;
  }

  fs::path write_text(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }

  io::PointTable scan_table(std::size_t n) {
    io::PointTable t;
    std::vector<double> red, green, blue, intensity, classification;
    for (const ScanPoint& p : scan_scene(n)) {
      t.positions.emplace_back(p.x, p.y, p.z);
      red.push_back(p.red);
      green.push_back(p.green);
      blue.push_back(p.blue);
      intensity.push_back(p.intensity);
      classification.push_back(p.classification);
    }
    t.set("intensity", io::ScalarType::UInt16, intensity);
    t.set("classification", io::ScalarType::UInt8, classification);
    t.set("red", io::ScalarType::UInt16, red);
    t.set("green", io::ScalarType::UInt16, green);
    t.set("blue", io::ScalarType::UInt16, blue);
    return t;
  }

  fs::path dir_;
};

// In core (2,000 points) and out of core (12,000 points over an 8 MiB budget).
constexpr std::size_t kInCorePoints = 2000, kOutOfCorePoints = 12000;

void expect_same_attributes(const io::PointTable& before, const io::PointTable& after) {
  ASSERT_EQ(after.size(), before.size());
  ASSERT_EQ(after.attributes.size(), before.attributes.size());
  for (std::size_t a = 0; a < before.attributes.size(); ++a) {
    EXPECT_EQ(after.attributes[a].name, before.attributes[a].name);
    EXPECT_EQ(after.attributes[a].type, before.attributes[a].type) << before.attributes[a].name;
    EXPECT_EQ(after.attributes[a].values, before.attributes[a].values) << before.attributes[a].name;
  }
  EXPECT_NE(after.positions, before.positions);  // the points did move
}

TEST_F(FaithfulOutput, HeaderlessThreeColumnXyzStaysHeaderlessThreeColumns) {
  for (const bool out_of_core : {false, true}) {
    std::string text;
    for (const ScanPoint& p : scan_scene(out_of_core ? kOutOfCorePoints : kInCorePoints))
      text += fixed3(p.x) + " " + fixed3(p.y) + " " + fixed3(p.z) + "\n";
    const fs::path in = write_text("scan.xyz", text), out = dir_ / "out.xyz";
    smooth(in, out, out_of_core);
    const std::vector<std::string> before = lines_of(text), after = lines_of(slurp(out));
    ASSERT_EQ(after.size(), before.size()) << "out of core: " << out_of_core;
    std::size_t moved = 0;
    for (std::size_t i = 0; i < after.size(); ++i) {
      ASSERT_EQ(split(after[i], ' ').size(), 3u) << "line " << i << ": " << after[i];
      moved += after[i] != before[i] ? 1 : 0;
    }
    EXPECT_GT(moved, 0u);
  }
}

TEST_F(FaithfulOutput, CommaCsvKeepsHeaderColumnsAndTheirText) {
  for (const bool out_of_core : {false, true}) {
    std::string text = "X,Y,Z,Red,Green,Blue,Intensity,Classification\n";
    for (const ScanPoint& p : scan_scene(out_of_core ? kOutOfCorePoints : kInCorePoints))
      text += fixed3(p.x) + "," + fixed3(p.y) + "," + fixed3(p.z) + "," + std::to_string(p.red) + "," +
              std::to_string(p.green) + "," + std::to_string(p.blue) + "," + std::to_string(p.intensity) + "," +
              std::to_string(p.classification) + "\n";
    const fs::path in = write_text("scan.csv", text), out = dir_ / "out.csv";
    smooth(in, out, out_of_core);
    const std::vector<std::string> before = lines_of(text), after = lines_of(slurp(out));
    ASSERT_EQ(after.size(), before.size());
    EXPECT_EQ(after[0], before[0]);
    for (std::size_t i = 1; i < after.size(); ++i) {
      const std::vector<std::string> b = split(before[i], ','), a = split(after[i], ',');
      ASSERT_EQ(a.size(), b.size()) << after[i];
      // Every attribute as the same text.
      for (std::size_t c = 3; c < b.size(); ++c) ASSERT_EQ(a[c], b[c]) << "line " << i << ": " << after[i];
    }
  }
}

TEST_F(FaithfulOutput, TabSeparatedPtsWithCountLineComesBackSo) {
  std::string text = std::to_string(kInCorePoints) + "\n";
  for (const ScanPoint& p : scan_scene(kInCorePoints))
    text += fixed3(p.x) + "\t" + fixed3(p.y) + "\t" + fixed3(p.z) + "\t" + std::to_string(p.intensity) + "\n";
  const fs::path in = write_text("scan.pts", text), out = dir_ / "out.pts";
  smooth(in, out, false);
  const std::vector<std::string> before = lines_of(text), after = lines_of(slurp(out));
  ASSERT_EQ(after.size(), before.size());
  EXPECT_EQ(after[0], before[0]);
  for (std::size_t i = 1; i < after.size(); ++i) {
    const std::vector<std::string> a = split(after[i], '\t');
    ASSERT_EQ(a.size(), 4u) << after[i];
    EXPECT_EQ(a[3], split(before[i], '\t')[3]);
  }
}

TEST_F(FaithfulOutput, AsciiPlyStaysAsciiWithItsColoursAndHeader) {
  for (const bool out_of_core : {false, true}) {
    io::PointTable t = scan_table(out_of_core ? kOutOfCorePoints : kInCorePoints);
    for (const char* name : {"red", "green", "blue"}) t.find(name)->type = io::ScalarType::UInt8;
    const fs::path in = dir_ / "scan.ply", out = dir_ / "out.ply";
    io::write_ply(in, t, io::PlyEncoding::Ascii);
    smooth(in, out, out_of_core);
    const std::string header_in = slurp(in).substr(0, slurp(in).find("end_header"));
    const std::string header_out = slurp(out).substr(0, slurp(out).find("end_header"));
    EXPECT_EQ(header_out, header_in);  // ascii, same comments, same properties in order
    expect_same_attributes(io::read_points(in), io::read_points(out));
  }
}

TEST_F(FaithfulOutput, BinaryBigEndianPlyStaysBigEndian) {
  const fs::path in = dir_ / "scan.ply", out = dir_ / "out.ply";
  io::write_ply(in, scan_table(kInCorePoints), io::PlyEncoding::BinaryBigEndian);
  smooth(in, out, false);
  EXPECT_NE(slurp(out).find("format binary_big_endian 1.0\n"), std::string::npos);
  expect_same_attributes(io::read_points(in), io::read_points(out));
}

TEST_F(FaithfulOutput, InputNormalsAreReplacedByTheNewOnesInTheirOrientation) {
  for (const bool out_of_core : {false, true}) {
    io::PointTable t = scan_table(out_of_core ? kOutOfCorePoints : kInCorePoints);
    // Normals pointing down (as if towards a scanner below), slightly off: stale on purpose.
    t.set("nx", io::ScalarType::Float32, std::vector<double>(t.size(), 0.1));
    t.set("ny", io::ScalarType::Float32, std::vector<double>(t.size(), 0.0));
    t.set("nz", io::ScalarType::Float32, std::vector<double>(t.size(), -0.995));
    const fs::path in = dir_ / "scan.ply", out = dir_ / "out.ply";
    io::write_ply(in, t);
    smooth(in, out, out_of_core);
    const io::PointTable r = io::read_points(out);
    ASSERT_EQ(r.size(), t.size());
    ASSERT_NE(r.find("nx"), nullptr);
    EXPECT_EQ(r.find("nx")->type, io::ScalarType::Float32);
    EXPECT_EQ(r.attributes.size(), t.attributes.size());  // replaced, not added
    EXPECT_EQ(r.find("red")->values, t.find("red")->values);
    std::size_t flat_ground = 0;
    for (std::size_t i = 0; i < r.size(); ++i) {
      const Vec3 n(r.find("nx")->values[i], r.find("ny")->values[i], r.find("nz")->values[i]);
      ASSERT_NEAR(n.norm(), 1.0, 1e-6) << i;
      EXPECT_LT(n.z(), 0.0) << i;  // the source's orientation: down
      flat_ground += std::abs(n.x()) < 0.05 && r.find("classification")->values[i] == 2 ? 1 : 0;
    }
    EXPECT_GT(flat_ground, r.size() / 2);  // no longer the stale 0.1
  }
}

TEST_F(FaithfulOutput, LasKeepsEveryFieldButTheCoordinates) {
  for (const bool out_of_core : {false, true}) {
    io::PointTable t = scan_table(out_of_core ? kOutOfCorePoints : kInCorePoints);
    std::vector<double> gps(t.size()), nir(t.size());
    for (std::size_t i = 0; i < t.size(); ++i) {
      gps[i] = 1.5e8 + 0.001 * static_cast<double>(i);
      nir[i] = static_cast<double>(i * 13 % 65536);
    }
    t.set("gps_time", io::ScalarType::Float64, gps);
    t.set("nir", io::ScalarType::UInt16, nir);
    t.set("scan_line", io::ScalarType::Int32, std::vector<double>(t.size(), -4));  // extra bytes
    const fs::path in = dir_ / "scan.las", out = dir_ / "out.las";
    io::write_las(in, t);
    smooth(in, out, out_of_core);
    const io::PointTable before = io::read_las(in), after = io::read_las(out);
    ASSERT_TRUE(after.las.has_value());
    EXPECT_EQ(after.las->point_format, before.las->point_format);
    EXPECT_EQ(after.las->point_format, 8);  // RGB and NIR
    EXPECT_EQ(after.las->extra_bytes_descriptors, before.las->extra_bytes_descriptors);
    EXPECT_EQ(after.quantization->scale, before.quantization->scale);
    EXPECT_EQ(after.quantization->offset, before.quantization->offset);
    expect_same_attributes(before, after);
    // Apart from the header's bounds and the X, Y, Z of each record, the same bytes.
    const std::string a = slurp(in), b = slurp(out);
    ASSERT_EQ(a.size(), b.size());
    const auto u32 = [&](std::size_t at) {
      std::uint32_t v = 0;
      std::memcpy(&v, a.data() + at, 4);
      return std::size_t{v};
    };
    const std::size_t first = u32(96), record = static_cast<std::uint8_t>(a[105]) + 256u * static_cast<std::uint8_t>(a[106]);
    EXPECT_EQ(b.substr(0, 90), a.substr(0, 90));              // up to the creation date
    EXPECT_EQ(b.substr(94, 179 - 94), a.substr(94, 179 - 94));  // up to the bounds
    EXPECT_EQ(b.substr(227, first - 227), a.substr(227, first - 227));  // point counts, VLRs
    std::size_t differing = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      const std::size_t at = first + i * record;
      ASSERT_EQ(b.substr(at + 12, record - 12), a.substr(at + 12, record - 12)) << "record " << i;
      differing += b.compare(at, 12, a, at, 12) != 0 ? 1 : 0;
    }
    EXPECT_GT(differing, 0u);
    const std::size_t end = first + t.size() * record;
    EXPECT_EQ(b.substr(end), a.substr(end));  // EVLRs
  }
}

TEST_F(FaithfulOutput, CurvatureColoursOnlyACloudWithoutColoursUnlessAsked) {
  io::PointTable t = scan_table(kInCorePoints);
  const fs::path in = dir_ / "scan.ply", out = dir_ / "out.ply";
  io::write_ply(in, t);
  std::string err;
  ASSERT_EQ(run("curvature " + in.string() + " " + out.string() + " --quiet", &err), 0) << err;
  EXPECT_EQ(io::read_points(out).find("red")->values, t.find("red")->values);
  ASSERT_EQ(run("curvature " + in.string() + " " + out.string() + " --quiet --colour-by kmax", &err), 0) << err;
  EXPECT_NE(io::read_points(out).find("red")->values, t.find("red")->values);
  io::PointTable plain;
  plain.positions = t.positions;
  const fs::path bare = dir_ / "bare.ply";
  io::write_ply(bare, plain);
  ASSERT_EQ(run("curvature " + bare.string() + " " + out.string() + " --quiet", &err), 0) << err;
  EXPECT_NE(io::read_points(out).find("red"), nullptr);
}

TEST_F(FaithfulOutput, SmoothAddsNoColoursUnlessAsked) {
  io::PointTable t;
  t.positions = scan_table(kInCorePoints).positions;
  const fs::path in = dir_ / "scan.ply", out = dir_ / "out.ply";
  io::write_ply(in, t);
  smooth(in, out, false);
  EXPECT_TRUE(io::read_points(out).attributes.empty());
  std::string err;
  ASSERT_EQ(run("smooth " + in.string() + " " + out.string() + " --steps 1 --quiet --colour-by laplacian", &err), 0)
      << err;
  EXPECT_NE(io::read_points(out).find("red"), nullptr);
}

}  // namespace

namespace {

// Six columns without a header read as x y z nx ny nz, but they are colours here: neither
// the normals nor --attributes may touch them, in core or out of core.
TEST_F(FaithfulOutput, HeaderlessSixColumnsAreNotTakenForNormals) {
  for (const bool out_of_core : {false, true}) {
    std::string text;
    for (const ScanPoint& p : scan_scene(out_of_core ? kOutOfCorePoints : kInCorePoints))
      text += fixed3(p.x) + " " + fixed3(p.y) + " " + fixed3(p.z) + " " + std::to_string(p.red) + " " +
              std::to_string(p.green) + " " + std::to_string(p.blue) + "\n";
    const fs::path in = write_text("scan.xyz", text), out = dir_ / "out.xyz";
    std::string err;
    const std::string budget = out_of_core ? " --memory-budget 8M" : "";
    ASSERT_EQ(run("smooth " + in.string() + " " + out.string() + " --steps 2 --quiet --attributes" + budget, &err), 0)
        << err;
    const std::vector<std::string> before = lines_of(text), after = lines_of(slurp(out));
    ASSERT_EQ(after.size(), before.size());
    for (std::size_t i = 0; i < after.size(); ++i) {
      const std::vector<std::string> b = split(before[i], ' '), a = split(after[i], ' ');
      ASSERT_EQ(a.size(), 6u + 14u) << after[i];  // no header; normal_x..feature_class appended
      for (std::size_t c = 3; c < 6; ++c) ASSERT_EQ(a[c], b[c]) << "line " << i;
    }
  }
}

}  // namespace
