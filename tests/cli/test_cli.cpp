// End-to-end tests of the pointfair command line: it runs, reports, and fails cleanly.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "pointfair/io/las.hpp"
#include "pointfair/io/ply.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/shapes/shapes.hpp"

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

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = fs::temp_directory_path() / ("pointfair_cli_" + std::to_string(rd()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  RunResult run(const std::string& args) {
    const fs::path out = dir_ / "stdout.txt", err = dir_ / "stderr.txt";
    const std::string command = std::string(POINTFAIR_EXE) + " " + args + " >" + out.string() +
                                " 2>" + err.string() + " </dev/null";
    const int status = std::system(command.c_str());
    RunResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    fs::remove(out);
    fs::remove(err);
    return r;
  }

  // The --json summary of `smooth IN OUT.ply --json --quiet OPTIONS`, which must succeed.
  std::string smooth_json(const fs::path& in, const std::string& options) {
    const RunResult r = run("smooth " + in.string() + " " + (dir_ / "out.ply").string() + " --json --quiet " + options);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.out;
  }

  // Files in the test directory other than `keep`.
  std::vector<std::string> files_except(std::initializer_list<std::string> keep) const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) {
      const std::string name = e.path().filename().string();
      if (std::find(keep.begin(), keep.end(), name) == keep.end()) names.push_back(name);
    }
    return names;
  }

  fs::path write_cloud(const std::string& name, std::size_t n = 2000) {
    io::PointTable t;
    t.positions = sample_sphere(n, 1.0, 3).points;
    add_noise(t.positions, 0.01, 4);
    std::vector<double> intensity(n);
    for (std::size_t i = 0; i < n; ++i) intensity[i] = static_cast<double>(i % 251);
    t.set("intensity", io::ScalarType::UInt16, intensity);
    const fs::path p = dir_ / name;
    io::write_points(p, t);
    return p;
  }

  fs::path write_bytes(const std::string& name, const std::string& bytes) {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }

  fs::path dir_;
};

// One line on stderr, naming `file`, and nothing written at `output`.
void expect_clean_failure(const RunResult& r, int code, const fs::path& file, const fs::path& output) {
  EXPECT_EQ(r.exit_code, code) << r.err;
  EXPECT_NE(r.err.find(file.filename().string()), std::string::npos) << r.err;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "expected one line, got: " << r.err;
  EXPECT_FALSE(fs::exists(output));
}

}  // namespace

TEST_F(CliTest, SmoothWritesResultAndJsonSummary) {
  const fs::path in = write_cloud("in.ply");
  const fs::path out = dir_ / "out.ply";
  const RunResult r = run("smooth " + in.string() + " " + out.string() + " --steps 5 --json --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"points\": 2000"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"steps\": 5"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"point_steps_per_second\""), std::string::npos);
  const io::PointTable t = io::read_points(out);
  ASSERT_EQ(t.size(), 2000u);
  // Extra properties are carried through unchanged; no colour unless --colour-by asks.
  const io::PointTable original = io::read_points(in);
  ASSERT_NE(t.find("intensity"), nullptr);
  EXPECT_EQ(t.find("intensity")->values, original.find("intensity")->values);
  EXPECT_EQ(t.find("red"), nullptr);
  // The points moved, but not far: the noise is 1% of the radius.
  double moved = 0;
  for (std::size_t i = 0; i < t.size(); ++i) moved = std::max(moved, (t.positions[i] - original.positions[i]).norm());
  EXPECT_GT(moved, 0.0);
  EXPECT_LT(moved, 0.2);
  EXPECT_TRUE(files_except({"in.ply", "out.ply"}).empty());
}

// --paper sets the paper's reading; an option after it overrides it.
TEST_F(CliTest, PaperPresetReachesTheParametersAndLaterOptionsOverrideIt) {
  const fs::path in = write_cloud("in.ply");
  const auto params = [&](const std::string& options) { return smooth_json(in, options); };
  const std::string defaults = params("--steps 1");
  EXPECT_NE(defaults.find("\"shrink_compensation\": 1,"), std::string::npos) << defaults;
  EXPECT_NE(defaults.find("\"cutoff_origin\": \"plane\""), std::string::npos) << defaults;
  const std::string paper = params("--paper --steps 1");
  for (const std::string field : {"\"shrink_compensation\": 0,", "\"stop_plateau\": 0,", "\"stop_lambda_ratio\": 0,",
                                  "\"tau\": 0.5,", "\"cutoff_origin\": \"point\"", "\"normal\": \"pca\""})
    EXPECT_NE(paper.find(field), std::string::npos) << field << " in " << paper;
  EXPECT_NE(paper.find("\"steps\": 1,"), std::string::npos) << paper;
  const std::string mixed = params("--paper --steps 1 --normal robust");
  EXPECT_NE(mixed.find("\"normal\": \"robust\""), std::string::npos) << mixed;
  // The feature threshold: the spacing rule by default, lambda (a number) under --paper.
  EXPECT_NE(defaults.find("\"feature_threshold\": \"auto\""), std::string::npos) << defaults;
  EXPECT_EQ(paper.find("\"feature_turn\""), std::string::npos) << paper;
  EXPECT_NE(params("--paper --steps 1 --feature-threshold auto").find("\"feature_threshold\": \"auto\""),
            std::string::npos);
}

// --feature-threshold: auto, lambda or a positive curvature.
TEST_F(CliTest, FeatureThresholdTakesAutoLambdaOrACurvature) {
  const fs::path in = write_cloud("in.ply", 500);
  EXPECT_NE(smooth_json(in, "--steps 1 --feature-turn 0.5").find("\"feature_turn\": 0.5"), std::string::npos);
  const std::string fixed = smooth_json(in, "--steps 1 --feature-threshold 2.5");
  EXPECT_NE(fixed.find("\"feature_threshold\": 2.5"), std::string::npos) << fixed;
  const std::string by_lambda = smooth_json(in, "--steps 1 --feature-threshold lambda");
  EXPECT_EQ(by_lambda.find("\"feature_threshold\": \"auto\""), std::string::npos) << by_lambda;
  for (const char* bad : {"0", "-1", "median"})
    EXPECT_EQ(run("smooth " + in.string() + " " + (dir_ / "o.ply").string() + " --feature-threshold " + bad).exit_code, 2)
        << bad;
  EXPECT_EQ(run("smooth " + in.string() + " " + (dir_ / "o.ply").string() + " --feature-turn -1").exit_code, 2);
  EXPECT_FALSE(fs::exists(dir_ / "o.ply"));
}

// --k auto (the default) reports the k it chose; a given k is used as given; --paper fixes 16.
TEST_F(CliTest, AutomaticKIsTheDefaultAndReported) {
  const fs::path in = write_cloud("in.ply");
  const auto json_of = [&](const std::string& options) { return smooth_json(in, "--steps 1 " + options); };
  // Noise of 0.13 sample spacings: the automatic k is the smallest.
  const std::string automatic = json_of("");
  EXPECT_NE(automatic.find("\"k\": 16, \"k_auto\": true"), std::string::npos) << automatic;
  const std::string given = json_of("--k 24");
  EXPECT_NE(given.find("\"k\": 24, \"k_auto\": false"), std::string::npos) << given;
  const std::string paper = json_of("--paper");
  EXPECT_NE(paper.find("\"k\": 16, \"k_auto\": false"), std::string::npos) << paper;
  EXPECT_EQ(run("smooth " + in.string() + " " + (dir_ / "out.ply").string() + " --k 0").exit_code, 2);
}

// A point file over --memory-budget runs out of core; the shrinkage compensation and the
// plateau stop reach that path: the same points and the same number of steps as in core, and
// not those of the uncompensated flow.
TEST_F(CliTest, OutOfCoreSmoothTakesCompensationAndPlateauStop) {
  const fs::path in = write_cloud("in.ply", 12000);
  const std::string method =
      " --steps 40 --shrink-compensation 1 --stop-plateau 0.03 --stop-lambda-ratio 0 --no-quadric-finish --threads 2 "
      "--json --quiet";
  const auto steps_of = [](const std::string& json) {
    const std::size_t at = json.find("\"steps\": ");
    return at == std::string::npos ? -1 : std::atoi(json.c_str() + at + 9);
  };
  const RunResult core = run("smooth " + in.string() + " " + (dir_ / "a.ply").string() + method);
  ASSERT_EQ(core.exit_code, 0) << core.err;
  EXPECT_EQ(core.out.find("\"out_of_core\": true"), std::string::npos) << core.out;
  const RunResult ooc = run("smooth " + in.string() + " " + (dir_ / "b.ply").string() + " --memory-budget 3M" + method);
  ASSERT_EQ(ooc.exit_code, 0) << ooc.err;
  EXPECT_NE(ooc.out.find("\"out_of_core\": true"), std::string::npos) << ooc.out;
  EXPECT_GT(steps_of(core.out), 8);
  EXPECT_EQ(steps_of(ooc.out), steps_of(core.out)) << core.out << "\n" << ooc.out;
  const io::PointTable a = io::read_points(dir_ / "a.ply"), b = io::read_points(dir_ / "b.ply");
  EXPECT_EQ(a.positions, b.positions);
  const RunResult plain = run("smooth " + in.string() + " " + (dir_ / "c.ply").string() +
                              " --memory-budget 3M --steps " + std::to_string(steps_of(core.out)) +
                              " --stop-lambda-ratio 0 --stop-plateau 0 --shrink-compensation 0 --no-quadric-finish "
                              "--threads 2 --quiet");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_NE(io::read_points(dir_ / "c.ply").positions, b.positions);
}

// Too small a --memory-budget for the run: exit 2 and a message that names the input, the
// budget, what the run needs and a budget that is taken. A point file leaves nothing behind;
// so does a container, whose tiles (of the import's budget) are imported again with the
// budget's tiles.
TEST_F(CliTest, TooSmallABudgetSaysWhatHelps) {
  const fs::path in = write_cloud("in.ply", 20000);
  const fs::path container = dir_ / "in.h5";
  ASSERT_EQ(run("import " + in.string() + " " + container.string() + " --quiet").exit_code, 0);
  for (const fs::path& input : {in, container}) {
    SCOPED_TRACE(input.string());
    const RunResult file = run("smooth " + input.string() + " " + (dir_ / "out.ply").string() +
                               " --memory-budget 256K --steps 2 --quiet");
    EXPECT_EQ(file.exit_code, 2) << file.err;
    EXPECT_NE(file.err.find("the memory budget of 256 KiB is too small for " + input.string() + " (the run needs "),
              std::string::npos)
        << file.err;
    EXPECT_NE(file.err.find("give a larger --memory-budget"), std::string::npos) << file.err;
    std::vector<std::string> left;
    for (const auto& e : fs::directory_iterator(dir_)) left.push_back(e.path().filename().string());
    std::sort(left.begin(), left.end());
    EXPECT_EQ(left, (std::vector<std::string>{"in.h5", "in.ply"}));
    // The budget it names is taken (with the tiles of that budget).
    const std::size_t named_at = file.err.find("--memory-budget, ");
    ASSERT_NE(named_at, std::string::npos) << file.err;
    const int named = std::atoi(file.err.c_str() + named_at + 17);
    EXPECT_NE(file.err.find(std::to_string(named) + " MiB or more"), std::string::npos) << file.err;
    const RunResult at_named = run("smooth " + input.string() + " " + (dir_ / "named.ply").string() +
                                   " --memory-budget " + std::to_string(named) + "M --steps 2 --quiet");
    EXPECT_EQ(at_named.exit_code, 0) << at_named.err;
    fs::remove(dir_ / "named.ply");
  }
}

// Tiles follow the budget: a container imported under a large budget (one tile) runs under
// a small one, imported again with that budget's tiles in the run's folder, to the in-core
// bits, into a point file and into a container; the folder goes when the run is done.
TEST_F(CliTest, AContainerImportedUnderALargeBudgetRunsUnderASmallOne) {
  const fs::path in = write_cloud("in.ply", 20000);
  const std::string method = " --steps 2 --no-quadric-finish --threads 2 --quiet";
  ASSERT_EQ(run("smooth " + in.string() + " " + (dir_ / "core.ply").string() + method).exit_code, 0);
  const fs::path container = dir_ / "in.h5";
  ASSERT_EQ(run("import " + in.string() + " " + container.string() + " --memory-budget 256M --quiet").exit_code, 0);
  const RunResult file = run("smooth " + container.string() + " " + (dir_ / "out.ply").string() +
                             " --memory-budget 2M --json" + method);
  ASSERT_EQ(file.exit_code, 0) << file.err;
  EXPECT_EQ(file.out.find("\"tiles\": 1,"), std::string::npos) << "not the case this test is for: " << file.out;
  EXPECT_EQ(io::read_points(dir_ / "out.ply").positions, io::read_points(dir_ / "core.ply").positions);
  const RunResult held = run("smooth " + container.string() + " " + (dir_ / "out.h5").string() +
                             " --memory-budget 2M" + method);
  ASSERT_EQ(held.exit_code, 0) << held.err;
  ASSERT_EQ(run("export " + (dir_ / "out.h5").string() + " " + (dir_ / "back.ply").string() + " --quiet").exit_code, 0);
  EXPECT_EQ(io::read_points(dir_ / "back.ply").positions, io::read_points(dir_ / "core.ply").positions);
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename().string().find(".pointfair-run"), std::string::npos) << e.path();
}

// --quadric-finish: the pass after the flow (on by default), reported in the JSON; it moves
// the points; bad values are refused with a message naming the problem; out of core it gives
// the same points.
TEST_F(CliTest, SmoothTakesTheQuadricFinishInAndOutOfCore) {
  const fs::path in = write_cloud("in.ply", 3000);
  EXPECT_NE(smooth_json(in, "--steps 3").find("\"quadric_finish\": {\"enabled\": true, \"k\": 200"),
            std::string::npos);
  const std::string plain = smooth_json(in, "--steps 3 --no-quadric-finish");
  EXPECT_NE(plain.find("\"quadric_finish\": {\"enabled\": false"), std::string::npos) << plain;
  const io::PointTable flow_only = io::read_points(dir_ / "out.ply");
  const std::string finished = smooth_json(in, "--steps 3 --quadric-finish --quadric-k 40 --quadric-angle 25");
  EXPECT_NE(finished.find("\"quadric_finish\": {\"enabled\": true, \"k\": 40, \"angle_degrees\": 25"),
            std::string::npos)
      << finished;
  EXPECT_NE(io::read_points(dir_ / "out.ply").positions, flow_only.positions);
  const RunResult bad = run("smooth " + in.string() + " " + (dir_ / "b.ply").string() + " --quadric-finish --quadric-k 3");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("quadric k"), std::string::npos) << bad.err;
  const std::string method = " --steps 3 --quadric-finish --quadric-k 40 --quadric-angle 25 --threads 2";
  const RunResult core = run("smooth " + in.string() + " " + (dir_ / "d.ply").string() + method + " --json --quiet");
  ASSERT_EQ(core.exit_code, 0) << core.err;
  EXPECT_EQ(core.out.find("\"out_of_core\": true"), std::string::npos) << core.out;
  const RunResult ooc = run("smooth " + in.string() + " " + (dir_ / "c.ply").string() + " --memory-budget 1M" +
                            method + " --json --quiet");
  ASSERT_EQ(ooc.exit_code, 0) << ooc.err;
  EXPECT_NE(ooc.out.find("\"out_of_core\": true"), std::string::npos) << ooc.out;
  EXPECT_NE(ooc.out.find("\"quadric_finish\": {\"enabled\": true, \"k\": 40"), std::string::npos) << ooc.out;
  EXPECT_EQ(io::read_points(dir_ / "c.ply").positions, io::read_points(dir_ / "d.ply").positions);
}

// --paper after --quadric-finish turns it off, options after --paper turn it on again, and
// --no-quadric-finish turns it off; the JSON reports the finish's degree and passes.
TEST_F(CliTest, PaperAndNoQuadricFinishLeaveTheFinishOut) {
  const fs::path in = write_cloud("in.ply", 2000);
  const std::string off = "\"quadric_finish\": {\"enabled\": false";
  const std::string on = "\"quadric_finish\": {\"enabled\": true";
  EXPECT_NE(smooth_json(in, "--quadric-finish --paper --steps 2").find(off), std::string::npos);
  const std::string again = smooth_json(in, "--paper --steps 2 --quadric-finish --quadric-k 30 --quadric-degree 2 --quadric-passes 1");
  EXPECT_NE(again.find(on), std::string::npos) << again;
  EXPECT_NE(again.find("\"degree\": 2, \"passes\": 1"), std::string::npos) << again;
  EXPECT_NE(smooth_json(in, "--steps 2 --quadric-finish --no-quadric-finish").find(off), std::string::npos);
  const RunResult bad = run("smooth " + in.string() + " " + (dir_ / "b.ply").string() + " --quadric-finish --quadric-degree 4");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("quadric degree"), std::string::npos) << bad.err;
}

// LAS in, LAS out: same point format and integer grid, per-point fields untouched.
TEST_F(CliTest, SmoothLasKeepsFormatAndFields) {
  io::PointTable t;
  t.positions = sample_sphere(2000, 10.0, 3).points;
  add_noise(t.positions, 0.1, 4);
  std::vector<double> classification(t.size()), intensity(t.size()), gps(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    classification[i] = static_cast<double>(i % 19);
    intensity[i] = static_cast<double>((i * 7919) % 65536);
    gps[i] = 1000.0 + 0.001 * static_cast<double>(i);
  }
  t.set("classification", io::ScalarType::UInt8, classification);
  t.set("intensity", io::ScalarType::UInt16, intensity);
  t.set("gps_time", io::ScalarType::Float64, gps);
  t.las = io::LasMetadata{};
  t.las->version_minor = 2;
  t.las->point_format = 1;
  t.quantization = io::PositionQuantization{Vec3(0.001, 0.001, 0.001), Vec3(0, 0, 0)};
  const fs::path in = dir_ / "in.las", out = dir_ / "out.las";
  io::write_las(in, t);
  const RunResult r = run("smooth " + in.string() + " " + out.string() + " --steps 5 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::PointTable original = io::read_las(in);
  const io::PointTable result = io::read_las(out);
  ASSERT_EQ(result.size(), original.size());
  ASSERT_TRUE(result.las.has_value());
  EXPECT_EQ(result.las->point_format, 1);
  EXPECT_EQ(result.las->version_minor, 2);
  EXPECT_EQ(result.quantization->scale, original.quantization->scale);
  EXPECT_EQ(result.quantization->offset, original.quantization->offset);
  for (const char* name : {"classification", "intensity", "gps_time", "return_number", "point_source_id"}) {
    ASSERT_NE(result.find(name), nullptr) << name;
    EXPECT_EQ(result.find(name)->values, original.find(name)->values) << name;
  }
  double moved = 0;
  for (std::size_t i = 0; i < result.size(); ++i)
    moved = std::max(moved, (result.positions[i] - original.positions[i]).norm());
  EXPECT_GT(moved, 0.0);
  EXPECT_LT(moved, 2.0);
  EXPECT_TRUE(files_except({"in.las", "out.las"}).empty());
}

// LAZ in, LAZ out (in core and out of core) gives the points and fields of LAS in, LAS out.
TEST_F(CliTest, SmoothLazGivesTheSamePointsAsLas) {
  io::PointTable t;
  t.positions = sample_sphere(3000, 10.0, 5).points;
  add_noise(t.positions, 0.1, 6);
  std::vector<double> classification(t.size()), gps(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    classification[i] = static_cast<double>(i % 7);
    gps[i] = 5000.0 + 1e-5 * static_cast<double>(i);
  }
  t.set("classification", io::ScalarType::UInt8, classification);
  t.set("gps_time", io::ScalarType::Float64, gps);
  t.las = io::LasMetadata{};
  t.las->version_minor = 2;
  t.las->point_format = 1;
  t.quantization = io::PositionQuantization{Vec3(0.001, 0.001, 0.001), Vec3(0, 0, 0)};
  io::write_las(dir_ / "in.las", t);
  io::write_las(dir_ / "in.laz", t, {.laz_chunk_size = 1000});
  const std::string method = " --steps 4 --no-quadric-finish --threads 2 --quiet";
  for (const std::string budget : {"", " --memory-budget 3M"}) {
    SCOPED_TRACE(budget);
    const fs::path las = dir_ / "out.las", laz = dir_ / "out.laz";
    const RunResult a = run("smooth " + (dir_ / "in.las").string() + " " + las.string() + budget + method);
    ASSERT_EQ(a.exit_code, 0) << a.err;
    const RunResult b = run("smooth " + (dir_ / "in.laz").string() + " " + laz.string() + budget + method);
    ASSERT_EQ(b.exit_code, 0) << b.err;
    std::ifstream header(laz, std::ios::binary);
    header.seekg(104);
    EXPECT_EQ(header.get(), 0x81);  // point format 1 with the compression bit
    const io::PointTable from_las = io::read_las(las), from_laz = io::read_las(laz);
    ASSERT_EQ(from_laz.size(), from_las.size());
    EXPECT_EQ(from_laz.positions, from_las.positions);
    ASSERT_EQ(from_laz.attributes.size(), from_las.attributes.size());
    for (std::size_t k = 0; k < from_las.attributes.size(); ++k) {
      EXPECT_EQ(from_laz.attributes[k].values, from_las.attributes[k].values) << from_las.attributes[k].name;
    }
  }
}

TEST_F(CliTest, CurvatureWritesEveryAttribute) {
  const fs::path in = write_cloud("in.ply", 4000);
  const fs::path out = dir_ / "curv.xyz";
  const RunResult r = run("curvature " + in.string() + " " + out.string() + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::PointTable t = io::read_points(out);
  for (const char* name : {"nx", "ny", "nz", "k1", "k2", "d1x", "d2z", "mean_curvature",
                           "laplacian_norm", "feature_class", "red"})
    EXPECT_NE(t.find(name), nullptr) << name;
  // A noisy unit sphere: the median mean curvature is near +1 (convex with outward normals).
  std::vector<double> h = t.find("mean_curvature")->values;
  std::nth_element(h.begin(), h.begin() + static_cast<long>(h.size() / 2), h.end());
  EXPECT_NEAR(h[h.size() / 2], 1.0, 0.35);
  // In a PLY file the attributes are named scalar_*, the names CloudCompare loads as scalar
  // fields; the normals and colours keep their standard names.
  const fs::path ply = dir_ / "curv.ply";
  ASSERT_EQ(run("curvature " + in.string() + " " + ply.string() + " --quiet").exit_code, 0);
  const io::PointTable p = io::read_points(ply);
  for (const char* name : {"nx", "ny", "nz", "scalar_k1", "scalar_k2", "scalar_d1x", "scalar_d2z",
                           "scalar_mean_curvature", "scalar_laplacian_norm", "scalar_feature_class", "red"})
    EXPECT_NE(p.find(name), nullptr) << name;
  EXPECT_EQ(p.find("k1"), nullptr);
  ASSERT_NE(p.find("scalar_mean_curvature"), nullptr);
  EXPECT_EQ(p.find("scalar_mean_curvature")->values.size(), t.find("mean_curvature")->values.size());
}

TEST_F(CliTest, HelpListsUnitsAndDefaults) {
  const RunResult r = run("smooth --help");
  ASSERT_EQ(r.exit_code, 0);
  for (const char* option : {"--k", "--eps", "--steps", "--tau", "--flow", "--cutoff", "--lambda",
                             "--constrain-normal", "--rebuild-every", "--neighbors-from",
                             "--features", "--edge-quotient", "--colour-by", "--json", "--threads"})
    EXPECT_NE(r.out.find(option), std::string::npos) << option;
  EXPECT_NE(r.out.find("1/length"), std::string::npos);
  EXPECT_NE(r.out.find("Default auto"), std::string::npos);
  EXPECT_NE(r.out.find("Default 150"), std::string::npos);
}

TEST_F(CliTest, BadArgumentsExitTwo) {
  const fs::path in = write_cloud("in.ply", 100);
  EXPECT_EQ(run("smooth " + in.string() + " " + (dir_ / "o.ply").string() + " --tau 7").exit_code, 2);
  EXPECT_EQ(run("smooth " + in.string() + " " + (dir_ / "o.ply").string() + " --bogus").exit_code, 2);
  EXPECT_EQ(run("smooth " + in.string()).exit_code, 2);
  EXPECT_EQ(run("frobnicate").exit_code, 2);
  EXPECT_FALSE(fs::exists(dir_ / "o.ply"));
}

TEST_F(CliTest, BadInputsFailCleanly) {
  const std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex 10\n"
                             "property float x\nproperty float y\nproperty float z\nend_header\n";
  const std::string nan_ascii = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                                "property float y\nproperty float z\nend_header\n0 0 0\nnan 1 2\n";
  const std::string count_too_large = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\n"
                                      "property float y\nproperty float z\nend_header\n0 0 0\n1 1 1\n";
  const std::string unknown_type = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float16 x\n"
                                   "property float y\nproperty float z\nend_header\n0 0 0\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"empty.ply", ""},
      {"truncated.ply", header + std::string(12 * 4 + 5, '\0')},
      {"count.ply", count_too_large},
      {"nan.ply", nan_ascii},
      {"type.ply", unknown_type},
      {"nan.xyz", "0 0 0\n1 nan 2\n"},
  };
  for (const auto& [name, bytes] : cases) {
    SCOPED_TRACE(name);
    const fs::path in = write_bytes(name, bytes);
    const fs::path out = dir_ / ("out_" + name + ".ply");
    expect_clean_failure(run("smooth " + in.string() + " " + out.string()), 3, in, out);
  }
  const fs::path unknown = write_bytes("cloud.foo", "0 0 0\n");
  expect_clean_failure(run("smooth " + unknown.string() + " " + (dir_ / "o.ply").string()), 3, unknown,
                       dir_ / "o.ply");
  const fs::path missing = dir_ / "missing.ply";
  expect_clean_failure(run("smooth " + missing.string() + " " + (dir_ / "o.ply").string()), 3, missing,
                       dir_ / "o.ply");
  // No temporary files left anywhere in the folder.
  for (const auto& name : files_except({})) EXPECT_EQ(name.find(".tmp"), std::string::npos) << name;
}

TEST_F(CliTest, OutputEqualToInputIsRefusedAndInputKept) {
  const fs::path in = write_cloud("in.ply", 500);
  const std::string before = slurp(in);
  const RunResult r = run("smooth " + in.string() + " " + in.string() + " --steps 2");
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.err.find("in.ply"), std::string::npos);
  EXPECT_EQ(slurp(in), before);
}

TEST_F(CliTest, UnwritableOutputFolderFailsCleanly) {
  const fs::path in = write_cloud("in.ply", 300);
  const fs::path out = dir_ / "no" / "such" / "folder" / "out.ply";
  const RunResult r = run("smooth " + in.string() + " " + out.string() + " --steps 1");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("out.ply"), std::string::npos) << r.err;
}

TEST_F(CliTest, NeighborsFromReferenceOfOtherSizeIsRejected) {
  const fs::path in = write_cloud("in.ply", 300);
  const fs::path ref = write_cloud("ref.ply", 200);
  const RunResult r = run("smooth " + in.string() + " " + (dir_ / "o.ply").string() +
                          " --neighbors-from " + ref.string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "o.ply"));
}

TEST_F(CliTest, DemoRunsOnSmallOctahedron) {
  const RunResult r = run("demo --out " + (dir_ / "demo").string() + " --level 3 --steps 5 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("anisotropic, 5 steps"), std::string::npos) << r.out;
  for (const char* f : {"octahedron_noisy.ply", "octahedron_aniso.ply", "octahedron_iso.ply", "summary.json"})
    EXPECT_TRUE(fs::exists(dir_ / "demo" / f)) << f;
  EXPECT_EQ(io::read_points(dir_ / "demo" / "octahedron_aniso.ply").size(), 258u);  // 4^4 + 2
}

// Width and height from a PNG's IHDR chunk (bytes 16..23).
std::array<std::uint32_t, 2> png_size(const fs::path& file) {
  const std::string bytes = slurp(file);
  if (bytes.size() < 24 || bytes.compare(12, 4, "IHDR") != 0) return {0, 0};
  auto be32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(bytes[at + i]);
    return v;
  };
  return {be32(16), be32(20)};
}

// The demo's picture: three 480-pixel panels, their labels above (28 pixels) and the colour
// legend under them (50 pixels).
TEST_F(CliTest, DemoPictureHasPanelsAndALegend) {
  ASSERT_EQ(run("demo --out " + (dir_ / "demo").string() + " --level 3 --steps 5 --quiet").exit_code, 0);
  EXPECT_EQ(png_size(dir_ / "demo" / "octahedron.png"), (std::array<std::uint32_t, 2>{3 * 480, 28 + 480 + 50}));
}

// render: a legend under a scalar-coloured picture, none under a uniform one; the same input
// gives the same bytes.
TEST_F(CliTest, RenderDrawsALegendForScalarColours) {
  const fs::path in = write_cloud("in.ply", 3000);
  const fs::path a = dir_ / "a.png", b = dir_ / "b.png", plain = dir_ / "plain.png";
  ASSERT_EQ(run("render " + in.string() + " " + a.string() + " --size 200").exit_code, 0);
  ASSERT_EQ(run("render " + in.string() + " " + b.string() + " --size 200 --threads 1").exit_code, 0);
  ASSERT_EQ(run("render " + in.string() + " " + plain.string() + " --size 200 --colour none").exit_code, 0);
  EXPECT_EQ(png_size(a), (std::array<std::uint32_t, 2>{200, 250}));
  EXPECT_EQ(png_size(plain), (std::array<std::uint32_t, 2>{200, 200}));
  EXPECT_EQ(slurp(a), slurp(b));
}

// Colours by a scalar are blue where it is low and red where it is high: on a cube, kmax is
// high at the edges and corners and low in the middle of the faces.
TEST_F(CliTest, ColourByKmaxIsBlueLowRedHigh) {
  io::PointTable t;
  t.positions = sample_mesh(cube_mesh(), 6000, 2).points;
  const fs::path in = dir_ / "cube.ply", out = dir_ / "coloured.ply";
  io::write_points(in, t);
  ASSERT_EQ(run("curvature " + in.string() + " " + out.string() + " --colour-by kmax --quiet").exit_code, 0);
  const io::PointTable r = io::read_points(out);
  const io::Attribute* red = r.find("red");
  const io::Attribute* blue = r.find("blue");
  ASSERT_TRUE(red && blue);
  // Edges and faces are found from the cloud's own box.
  Eigen::AlignedBox3d box;
  for (const Vec3& p : r.positions) box.extend(p);
  const double size = box.sizes().maxCoeff();
  double red_at_edges = 0, blue_at_edges = 0, red_on_faces = 0, blue_on_faces = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    const Vec3 p = r.positions[i];
    // Distance to the box's boundary along each axis; two small ones: near an edge.
    int near = 0, far = 0;
    for (int c = 0; c < 3; ++c) {
      const double d = std::min(p[c] - box.min()[c], box.max()[c] - p[c]);
      if (d < 0.02 * size) ++near;
      if (d > 0.25 * size) ++far;
    }
    if (near >= 2) {
      red_at_edges += red->values[i];
      blue_at_edges += blue->values[i];
    } else if (far == 2) {
      red_on_faces += red->values[i];
      blue_on_faces += blue->values[i];
    }
  }
  EXPECT_GT(red_at_edges, 1.2 * blue_at_edges) << "edges red";
  EXPECT_GT(blue_on_faces, 2 * red_on_faces) << "faces blue, " << blue_on_faces << " vs " << red_on_faces;
}

TEST_F(CliTest, ThreadsGiveIdenticalOutput) {
  const fs::path in = write_cloud("in.ply", 3000);
  ASSERT_EQ(run("smooth " + in.string() + " " + (dir_ / "a.ply").string() + " --steps 4 --threads 1 --quiet").exit_code, 0);
  ASSERT_EQ(run("smooth " + in.string() + " " + (dir_ / "b.ply").string() + " --steps 4 --threads 2 --quiet").exit_code, 0);
  EXPECT_EQ(slurp(dir_ / "a.ply"), slurp(dir_ / "b.ply"));
}

namespace {

// The number after `key` in a JSON text ("key": N), or -1.
double json_number_after(const std::string& json, const std::string& key) {
  const std::size_t at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return -1.0;
  return std::stod(json.substr(at + key.size() + 4));
}

class CliInfoTest : public CliTest {
 protected:
  // A noisy sphere as LAS with the given coordinate system records; noise 3x that of
  // write_cloud, so that the automatic k is above its minimum.
  fs::path write_las(const std::string& name, std::vector<io::LasRecord> records) {
    io::PointTable t;
    t.positions = sample_sphere(3000, 1.0, 5).points;
    add_noise(t.positions, 0.03, 6);
    std::vector<double> classification(t.size());
    for (std::size_t i = 0; i < t.size(); ++i) classification[i] = i % 3 == 0 ? 6.0 : 2.0;
    t.set("classification", io::ScalarType::UInt8, classification);
    t.las = io::LasMetadata{};
    t.las->records = std::move(records);
    const fs::path p = dir_ / name;
    io::write_points(p, t);
    return p;
  }
};

TEST_F(CliInfoTest, DescribesALasFileWithItsCrsAndTheKTheDefaultsChoose) {
  const std::string wkt =
      "PROJCS[\"CH1903+ / LV95\",GEOGCS[\"CH1903+\",AUTHORITY[\"EPSG\",\"4150\"]],"
      "PROJECTION[\"Hotine_Oblique_Mercator_Azimuth_Center\"],AUTHORITY[\"EPSG\",\"2056\"]]";
  const fs::path in = write_las("scan.las", {{"LASF_Projection", 2112, "WKT", wkt + '\0', false}});
  const RunResult text = run("info " + in.string());
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("LAS 1.4"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("3,000 points"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("EPSG:2056 \"CH1903+ / LV95\""), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("classification"), std::string::npos) << text.out;
  // The finish's passes as the defaults run them: the first one not reweighted.
  EXPECT_NE(text.out.find("then the finish: 2 passes of fits over 200 neighbours (the last degree 3, reweighted "
                          "once; before it degree 3, not reweighted)"),
            std::string::npos)
      << text.out;
  const RunResult json = run("info " + in.string() + " --json");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_EQ(json_number_after(json.out, "points"), 3000.0) << json.out;
  EXPECT_NE(json.out.find("\"classification\": {\"type\": \"uchar\", \"min\": 2, \"max\": 6}"), std::string::npos)
      << json.out;
  // The k it predicts is the one smooth chooses.
  const double k = json_number_after(json.out.substr(json.out.find("\"defaults\"")), "k");
  const std::string smoothed = smooth_json(in, "--steps 1");
  EXPECT_GT(k, 16.0) << json.out;
  EXPECT_EQ(json_number_after(smoothed, "k"), k) << smoothed;
}

// Noise of a few sample spacings gets a hint at the options that need fewer steps; light
// noise none.
TEST_F(CliInfoTest, HeavyNoiseGetsTheHintOfFewerSteps) {
  const auto info_of = [&](const std::string& name, double sigma) {
    io::PointTable t;
    t.positions = sample_sphere(6000, 1.0, 7).points;
    add_noise(t.positions, sigma, 8);
    io::write_points(dir_ / name, t);
    const RunResult r = run("info " + (dir_ / name).string());
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.out;
  };
  const std::string heavy = info_of("heavy.ply", 0.3), light = info_of("light.ply", 0.002);
  EXPECT_NE(heavy.find("--no-coarse-level"), std::string::npos) << heavy;
  EXPECT_NE(heavy.find("1 pass of fits"), std::string::npos) << heavy;
  EXPECT_EQ(light.find("coarse-level"), std::string::npos) << light;
  EXPECT_NE(light.find("2 passes of fits"), std::string::npos) << light;
}

TEST_F(CliInfoTest, ReadsTheEpsgCodeOfGeoTiffKeys) {
  // GeoKeyDirectory: version 1.1.0, 2 keys; GTModelType projected, ProjectedCSType 32633.
  std::string keys;
  for (const int w : {1, 1, 0, 2, 1024, 0, 1, 1, 3072, 0, 1, 32633}) {
    keys += static_cast<char>(w & 0xff);
    keys += static_cast<char>((w >> 8) & 0xff);
  }
  const fs::path in = write_las("utm.las", {{"LASF_Projection", 34735, "GeoKeys", keys, false}});
  const RunResult r = run("info " + in.string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"crs\": \"EPSG:32633 (GeoTIFF keys)\""), std::string::npos) << r.out;
  const fs::path plain = write_las("plain.las", {});
  EXPECT_NE(run("info " + plain.string()).out.find("CRS        none"), std::string::npos);
}

TEST_F(CliInfoTest, AFolderIsDescribedFileByFileWithItsTotal) {
  fs::create_directories(dir_ / "tiles");
  io::write_points(dir_ / "tiles" / "b.ply", io::read_points(write_cloud("b.ply", 1000)));
  io::write_points(dir_ / "tiles" / "a.xyz", io::read_points(write_cloud("a.ply", 500)));
  std::ofstream(dir_ / "tiles" / "notes.md") << "not a point file";
  const RunResult r = run("info " + (dir_ / "tiles").string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(json_number_after(r.out, "points"), 1500.0) << r.out;
  EXPECT_LT(r.out.find("\"a.xyz\""), r.out.find("\"b.ply\"")) << r.out;
  EXPECT_EQ(r.out.find("notes.md"), std::string::npos) << r.out;
  // A budget too small for the estimate: the rest is still described.
  const RunResult small = run("info " + (dir_ / "tiles" / "b.ply").string() + " --memory-budget 100K");
  ASSERT_EQ(small.exit_code, 0) << small.err;
  EXPECT_NE(small.out.find("not measured"), std::string::npos) << small.out;
  // Nothing to describe: one line naming the path, exit code 3.
  fs::create_directories(dir_ / "empty");
  const RunResult empty = run("info " + (dir_ / "empty").string());
  EXPECT_EQ(empty.exit_code, 3);
  EXPECT_NE(empty.err.find("empty"), std::string::npos) << empty.err;
  const RunResult missing = run("info " + (dir_ / "missing.las").string());
  EXPECT_EQ(missing.exit_code, 3);
  EXPECT_NE(missing.err.find("missing.las"), std::string::npos) << missing.err;
}

}  // namespace
