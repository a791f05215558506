// End-to-end: `pointfair smooth --classes LIST` (and --returns) moves the selected points
// only, as if the file held nothing else, and writes every other record back byte for byte,
// in core and out of core alike.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "pointfair/io/las.hpp"
#include "pointfair/io/ply.hpp"
#include "pointfair/io/point_file.hpp"

namespace fs = std::filesystem;
using namespace pointfair;

namespace {

struct RunResult {
  int exit_code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

template <typename T>
T field(const std::string& bytes, std::size_t at) {
  T value{};
  std::memcpy(&value, bytes.data() + at, sizeof value);
  return value;
}

// A LAS file's raw parts: the VLRs (between the header and the points) and each point record.
struct RawLas {
  std::string vlrs;
  std::vector<std::string> records;
};

RawLas raw_las(const fs::path& p) {
  const std::string bytes = slurp(p);
  RawLas raw;
  const auto header_size = field<std::uint16_t>(bytes, 94);
  const auto offset = field<std::uint32_t>(bytes, 96);
  const auto length = field<std::uint16_t>(bytes, 105);
  const auto count = field<std::uint64_t>(bytes, 247);  // LAS 1.4
  raw.vlrs = bytes.substr(header_size, offset - header_size);
  for (std::uint64_t i = 0; i < count; ++i) raw.records.push_back(bytes.substr(offset + i * length, length));
  return raw;
}

constexpr int kGround = 2, kVegetation = 5;

// Ground (class 2, last of its pulse's returns) under vegetation (class 5, first of two
// returns) over the same 20 m square, interleaved in file order: one point in three is a
// leaf 0.3 to 3 m above the ground, close enough to be a ground point's neighbour.
io::PointTable scene(std::size_t n) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.03);
  io::PointTable t;
  std::vector<double> classification, return_number, number_of_returns, intensity;
  for (std::size_t i = 0; i < n; ++i) {
    const bool leaf = i % 3 == 1;
    const double x = 500000.0 + 20.0 * u(rng), y = 4200000.0 + 20.0 * u(rng);
    const double z = 100.0 + 0.02 * (x - 500000.0) + (leaf ? 0.3 + 2.7 * u(rng) : noise(rng));
    t.positions.emplace_back(x, y, z);
    classification.push_back(leaf ? kVegetation : kGround);
    return_number.push_back(leaf ? 1 : i % 3 == 0 ? 2 : 1);
    number_of_returns.push_back(leaf ? 2 : i % 3 == 0 ? 2 : 1);
    intensity.push_back(static_cast<double>(i * 7919 % 65536));
  }
  t.set("intensity", io::ScalarType::UInt16, intensity);
  t.set("return_number", io::ScalarType::UInt8, return_number);
  t.set("number_of_returns", io::ScalarType::UInt8, number_of_returns);
  t.set("classification", io::ScalarType::UInt8, classification);
  t.quantization = io::PositionQuantization{Vec3::Constant(0.001), Vec3(500000.0, 4200000.0, 0.0)};
  t.las = io::LasMetadata{};
  t.las->version_minor = 4;
  t.las->point_format = 6;
  t.las->records.push_back({"LASF_Projection", 2112, "WKT", "PROJCS[\"WGS 84 / UTM zone 33N\"]", false});
  return t;
}

// The rows of `t` whose classification is `code`, as a table of their own.
io::PointTable only_class(const io::PointTable& t, int code) {
  io::PointTable part = t;
  part.positions.clear();
  for (auto& a : part.attributes) a.values.clear();
  const auto& classes = t.find("classification")->values;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (classes[i] != code) continue;
    part.positions.push_back(t.positions[i]);
    for (std::size_t a = 0; a < t.attributes.size(); ++a) part.attributes[a].values.push_back(t.attributes[a].values[i]);
  }
  return part;
}

// A number after "key": in a JSON text, or -1.
double json_number(const std::string& json, const std::string& key) {
  const std::size_t at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return -1.0;
  return std::stod(json.substr(at + key.size() + 4));
}

class SmoothSelection : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = fs::temp_directory_path() / ("pointfair_selection_" + std::to_string(rd()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  RunResult run(const std::string& args) {
    const fs::path out = dir_ / "stdout.txt", err = dir_ / "stderr.txt";
    const std::string command = std::string(POINTFAIR_EXE) + " " + args + " >" + out.string() + " 2>" +
                                err.string() + " </dev/null";
    const int status = std::system(command.c_str());
    RunResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    fs::remove(out);
    fs::remove(err);
    return r;
  }

  // smooth IN OUT --steps 3 OPTIONS --json --quiet, which must succeed; returns the summary.
  std::string smooth(const fs::path& in, const fs::path& out, const std::string& options) {
    const RunResult r = run("smooth " + in.string() + " " + out.string() + " --steps 3 --k 16 --json --quiet " + options);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.out;
  }

  fs::path write(const std::string& name, const io::PointTable& t) {
    const fs::path p = dir_ / name;
    io::write_points(p, t);
    return p;
  }

  fs::path dir_;
};

// In core (1,500 points) and out of core (12,000 points over an 8 MiB budget, several tiles).
constexpr std::size_t kInCorePoints = 1500, kOutOfCorePoints = 12000;

TEST_F(SmoothSelection, OtherClassesComeBackByteForByteAndTheSelectedMoveAsIfAlone) {
  for (const bool out_of_core : {false, true}) {
    SCOPED_TRACE(out_of_core ? "out of core" : "in core");
    const io::PointTable t = scene(out_of_core ? kOutOfCorePoints : kInCorePoints);
    const std::string budget = out_of_core ? " --memory-budget 8M" : "";
    const fs::path in = write("scene.las", t), out = dir_ / "out.las";
    const std::string json = smooth(in, out, "--classes 2" + budget);
    if (out_of_core) {
      EXPECT_GT(json_number(json, "tiles"), 1.0) << json;
    }

    const RawLas before = raw_las(in), after = raw_las(out);
    EXPECT_EQ(after.vlrs, before.vlrs);
    ASSERT_EQ(after.records.size(), before.records.size());
    const auto& classes = t.find("classification")->values;
    std::size_t ground = 0, moved = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (classes[i] == kGround) {
        ++ground;
        moved += after.records[i] != before.records[i] ? 1 : 0;
      } else {
        ASSERT_EQ(after.records[i], before.records[i]) << "record " << i << " (vegetation) changed";
      }
    }
    EXPECT_GT(moved, ground / 2);
    EXPECT_EQ(json_number(json, "points"), static_cast<double>(t.size())) << json;
    EXPECT_EQ(json_number(json, "selected_points"), static_cast<double>(ground)) << json;
    EXPECT_GT(json_number(json, "moved_points"), static_cast<double>(ground / 2)) << json;

    // The ground alone, smoothed in core: the same positions to the bit, so the vegetation was
    // no neighbour of any ground point.
    const fs::path alone = write("ground.las", only_class(t, kGround)), alone_out = dir_ / "ground_out.las";
    smooth(alone, alone_out, "");
    const io::PointTable expected = io::read_las(alone_out), result = io::read_las(out);
    std::size_t j = 0;
    for (std::size_t i = 0; i < t.size(); ++i)
      if (classes[i] == kGround) {
        ASSERT_EQ(result.positions[i], expected.positions[j++]) << "point " << i;
      }
    EXPECT_EQ(j, expected.size());
    // Out of core wrote what in core writes, to the byte.
    if (out_of_core) {
      const fs::path core = dir_ / "core.las";
      smooth(in, core, "--classes 2");
      EXPECT_TRUE(slurp(core) == slurp(out)) << "in-core and out-of-core outputs differ";
    }
  }
}

// A PLY with normals and a CSV with a header, each with a class column: out of core writes
// what in core writes (normals of the selected points refreshed, the others' kept), and with
// the automatic k, eps and lambda the selected points move as if alone.
TEST_F(SmoothSelection, PlyWithNormalsAndCsvOutOfCoreMatchInCore) {
  io::PointTable t = scene(kOutOfCorePoints);
  t.quantization.reset();
  t.las.reset();
  const std::vector<double> classes = t.find("classification")->values;
  t.attributes.clear();
  t.set("nx", io::ScalarType::Float32, std::vector<double>(t.size(), 0.0));
  t.set("ny", io::ScalarType::Float32, std::vector<double>(t.size(), 0.0));
  t.set("nz", io::ScalarType::Float32, std::vector<double>(t.size(), -1.0));
  t.set("classification", io::ScalarType::UInt8, classes);
  for (const char* name : {"scene.ply", "scene.csv"}) {
    SCOPED_TRACE(name);
    const fs::path in = write(name, t);
    const std::string ext = fs::path(name).extension().string();
    const fs::path core = dir_ / ("core" + ext), tiled = dir_ / ("tiled" + ext);
    const RunResult r = run("smooth " + in.string() + " " + core.string() + " --steps 2 --quiet --threads 1 --classes 2");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const RunResult o = run("smooth " + in.string() + " " + tiled.string() +
                            " --steps 2 --quiet --classes 2 --memory-budget 8M --json");
    ASSERT_EQ(o.exit_code, 0) << o.err;
    EXPECT_GT(json_number(o.out, "tiles"), 1.0) << o.out;
    EXPECT_TRUE(slurp(core) == slurp(tiled)) << "in-core and out-of-core outputs differ";
    const io::PointTable before = io::read_points(in), after = io::read_points(tiled);
    ASSERT_EQ(after.size(), before.size());
    std::size_t turned = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      const bool ground = classes[i] == kGround;
      for (const char* n : {"nx", "ny", "nz"}) {
        const double a = after.find(n)->values[i], b = before.find(n)->values[i];
        if (!ground) {
          ASSERT_EQ(a, b) << n << " of point " << i;
        } else {
          turned += a != b ? 1 : 0;
        }
      }
      if (!ground) {
        ASSERT_EQ(after.positions[i], before.positions[i]) << "point " << i;
      }
    }
    EXPECT_GT(turned, 0u);
    if (ext != ".ply") continue;
    // The automatic k, eps and lambda (no --k) are those of the ground alone.
    const fs::path alone = write("alone.ply", only_class(t, kGround)), alone_out = dir_ / "alone_out.ply";
    ASSERT_EQ(run("smooth " + alone.string() + " " + alone_out.string() + " --steps 2 --quiet").exit_code, 0);
    const io::PointTable expected = io::read_points(alone_out);
    std::size_t j = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (classes[i] == kGround) {
        ASSERT_EQ(after.positions[i], expected.positions[j++]) << "point " << i;
      }
    }
  }
}

TEST_F(SmoothSelection, LastReturnsSelectTheGroundHere) {
  const io::PointTable t = scene(kInCorePoints);
  const fs::path in = write("scene.las", t), by_class = dir_ / "class.las", by_return = dir_ / "return.las";
  smooth(in, by_class, "--classes 2");
  const std::string json = smooth(in, by_return, "--returns last");
  EXPECT_TRUE(slurp(by_class) == slurp(by_return));
  EXPECT_NE(json.find("\"returns\": \"last\""), std::string::npos) << json;
  // First returns are the leaves and a third of the ground: other points than the last.
  const fs::path first = dir_ / "first.las";
  smooth(in, first, "--returns first --classes 0-4");  // the ground points that are first returns
  const RawLas before = raw_las(in), after = raw_las(first);
  const auto& classes = t.find("classification")->values;
  const auto& number = t.find("return_number")->values;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (classes[i] != kGround || number[i] != 1) {
      ASSERT_EQ(after.records[i], before.records[i]) << "record " << i;
    }
}

TEST_F(SmoothSelection, ClassesNoPointHasWriteTheFileBackAsItWas) {
  for (const bool out_of_core : {false, true}) {
    SCOPED_TRACE(out_of_core ? "out of core" : "in core");
    const io::PointTable t = scene(out_of_core ? kOutOfCorePoints : kInCorePoints);
    const fs::path in = write("scene.las", t), out = dir_ / "out.las";
    const std::string json = smooth(in, out, std::string("--classes 7,9-12") + (out_of_core ? " --memory-budget 8M" : ""));
    const RawLas before = raw_las(in), after = raw_las(out);
    EXPECT_EQ(after.vlrs, before.vlrs);
    EXPECT_EQ(after.records, before.records);
    EXPECT_EQ(json_number(json, "selected_points"), 0.0) << json;
    EXPECT_EQ(json_number(json, "moved_points"), 0.0) << json;
    fs::remove(out);
  }
}

TEST_F(SmoothSelection, PlyWithAClassPropertyIsSelectedByIt) {
  io::PointTable t = scene(kInCorePoints);
  t.quantization.reset();
  t.las.reset();
  t.attributes = {{"class", io::ScalarType::UInt8, t.find("classification")->values}};
  const fs::path in = write("scene.ply", t), out = dir_ / "out.ply";
  smooth(in, out, "--classes 5");
  const io::PointTable before = io::read_ply(in), after = io::read_ply(out);
  ASSERT_EQ(after.size(), before.size());
  std::size_t moved = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (before.attributes[0].values[i] != kVegetation) {
      ASSERT_EQ(after.positions[i], before.positions[i]) << i;
    } else {
      moved += after.positions[i] != before.positions[i] ? 1 : 0;
    }
  }
  EXPECT_GT(moved, 0u);
  EXPECT_EQ(after.attributes[0].values, before.attributes[0].values);
}

// The container of an interrupted run holds the points its selection kept: a --resume with
// another selection (here: a run of every point, resumed with --classes) is refused.
TEST_F(SmoothSelection, AResumeWithAnotherSelectionIsRefused) {
  const fs::path in = write("scene.las", scene(kOutOfCorePoints)), out = dir_ / "out.las";
  const fs::path work = dir_ / ".out.las.pointfair-run";
  fs::create_directories(work);
  ASSERT_EQ(run("import " + in.string() + " " + (work / "input.h5").string() + " --quiet").exit_code, 0);
  const RunResult r = run("smooth " + in.string() + " " + out.string() + " --classes 2 --memory-budget 8M --resume");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("--classes or --returns"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(work / "input.h5"));  // an interrupted run's folder is left alone
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(SmoothSelection, BadListsAndFilesWithoutClassesFailCleanly) {
  const fs::path in = write("scene.las", scene(300)), out = dir_ / "out.las";
  for (const char* list : {"2,x", "256", "-1", "6-2", "", "2,,6", "2-"}) {
    const RunResult r = run("smooth " + in.string() + " " + out.string() + " --classes=" + list);
    EXPECT_EQ(r.exit_code, 2) << list << ": " << r.err;
    EXPECT_NE(r.err.find("--classes"), std::string::npos) << r.err;
  }
  for (const char* returns : {"second", "16", "1-x"}) {
    const RunResult r = run("smooth " + in.string() + " " + out.string() + " --returns " + returns);
    EXPECT_EQ(r.exit_code, 2) << returns << ": " << r.err;
    EXPECT_NE(r.err.find("--returns"), std::string::npos) << r.err;
  }
  for (const char* extra : {"--attributes", "--colour-by kmax"}) {
    const RunResult r = run("smooth " + in.string() + " " + out.string() + " --classes 2 " + extra);
    EXPECT_EQ(r.exit_code, 2) << extra << ": " << r.err;
  }
  const RunResult container = run("smooth " + in.string() + " " + (dir_ / "out.h5").string() + " --classes 2");
  EXPECT_EQ(container.exit_code, 2) << container.err;
  EXPECT_NE(container.err.find("container"), std::string::npos) << container.err;

  io::PointTable plain;
  plain.positions = scene(300).positions;
  plain.set("intensity", io::ScalarType::UInt16, std::vector<double>(plain.size(), 1.0));
  const fs::path ply = write("plain.ply", plain);
  for (const std::string budget : {"", " --memory-budget 8M"}) {
    const RunResult r = run("smooth " + ply.string() + " " + (dir_ / "o.ply").string() + " --classes 2" + budget);
    EXPECT_EQ(r.exit_code, 3) << r.err;
    EXPECT_NE(r.err.find(ply.string() + ": has no classification"), std::string::npos) << r.err;
    const RunResult returns = run("smooth " + ply.string() + " " + (dir_ / "o.ply").string() + " --returns last" + budget);
    EXPECT_EQ(returns.exit_code, 3) << returns.err;
    EXPECT_NE(returns.err.find("return_number"), std::string::npos) << returns.err;
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir_ / "o.ply"));
}

}  // namespace
