// The coarse level out of core (SmoothParams::coarse): smooth()'s bits over small tiles, one
// level and two; stopped in its own run or in the fine run and resumed; skipped under light
// noise as in core; its work folder kept for a resume and never taken from the user.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/neighbors/neighborhood_size.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

using test::expect_identical;
using test::InCore;
using test::run_in_core;

using TiledCoarseLevelTest = test::ThreadsTempDirTest;

constexpr std::uint64_t kLarge = std::uint64_t{64} << 20, kSmall = std::uint64_t{2} << 20;

// A unit sphere under noise of 1.6 sample spacings: the coarse level's case from 1.5 on
// (with_coarse_level), small enough for the tests.
io::PointTable heavy_noise_sphere() {
  io::PointTable cloud;
  cloud.positions = sample_sphere(12000, 1.0, 41).points;
  add_noise(cloud.positions, 0.07, 42);
  EXPECT_GE(estimate_noise(cloud.positions).ratio, 1.5) << "not the case this test is for";
  return cloud;
}

SmoothParams with_coarse_level(int levels = 1) {
  SmoothParams params;
  params.coarse = CoarseLevelParams{};
  params.coarse->levels = levels;
  params.coarse->min_noise_ratio = 1.5;
  return params;
}

std::filesystem::path folder_of(const std::filesystem::path& output) {
  const std::filesystem::path folder = coarse_folder_name(output);
  EXPECT_EQ(folder.filename(), output.filename().string() + ".partial.coarse");
  return folder;
}

void expect_same_levels(const std::vector<CoarseLevelReport>& a, const std::vector<CoarseLevelReport>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].points, b[i].points) << "level " << i;
    EXPECT_EQ(a[i].steps, b[i].steps) << "level " << i;
  }
}

TEST_F(TiledCoarseLevelTest, GivesTheInCoreBitsOverSmallTiles) {
  const io::PointTable cloud = heavy_noise_sphere();
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 300}, 256));
  set_thread_count(2);
  for (const int levels : {1, 2}) {
    const SmoothParams params = with_coarse_level(levels);
    const InCore ref = run_in_core(cloud, params);
    ASSERT_EQ(ref.report.coarse_levels.size(), static_cast<std::size_t>(levels));
    // Held positions and cached lists, and streamed tiles (one level is enough for that).
    for (const std::uint64_t budget : levels == 1 ? std::vector<std::uint64_t>{kLarge, kSmall}
                                                  : std::vector<std::uint64_t>{kLarge}) {
      SCOPED_TRACE(testing::Message() << levels << " levels, budget " << budget);
      OutOfCoreOptions options;
      options.memory_budget = budget;
      const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
      EXPECT_TRUE(r.finished);
      EXPECT_GT(r.tiles, 10u);
      EXPECT_EQ(r.steps, ref.report.steps);
      EXPECT_EQ(r.k, ref.report.k);
      expect_same_levels(r.coarse_levels, ref.report.coarse_levels);
      expect_identical(path("run.h5"), ref);
      EXPECT_FALSE(std::filesystem::exists(folder_of(path("run.h5")))) << "the work folder is left behind";
      std::filesystem::remove(path("run.h5"));
    }
  }
}

TEST_F(TiledCoarseLevelTest, StoppedInEitherRunAndResumed) {
  const io::PointTable cloud = heavy_noise_sphere();
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 500}, 256));
  const SmoothParams params = with_coarse_level();
  const InCore ref = run_in_core(cloud, params);
  OutOfCoreOptions options;
  options.memory_budget = kLarge;
  // In the coarse sample's own run (its steps), then in the fine run (its finish).
  for (const bool in_fine_run : {false, true}) {
    SCOPED_TRACE(in_fine_run ? "stopped in the fine run" : "stopped in the coarse run");
    OutOfCoreOptions stopping = options;
    if (in_fine_run)
      stopping.stop_after_finish_passes = 1;
    else
      stopping.stop_after_steps = 2;
    const OutOfCoreReport stopped = smooth_out_of_core(path("in.h5"), path("run.h5"), params, stopping);
    EXPECT_FALSE(stopped.finished);
    EXPECT_TRUE(std::filesystem::is_directory(folder_of(path("run.h5"))));
    EXPECT_FALSE(std::filesystem::exists(path("run.h5")));
    // Not without --resume: the interrupted run is kept.
    EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("run.h5"), params, options), std::runtime_error);
    // Nor with other parameters.
    OutOfCoreOptions resuming = options;
    resuming.resume = true;
    SmoothParams other = params;
    other.coarse->interpolation_k = 6;
    EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("run.h5"), other, resuming), ParamError);
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, resuming);
    EXPECT_TRUE(r.finished);
    expect_identical(path("run.h5"), ref);
    EXPECT_FALSE(std::filesystem::exists(folder_of(path("run.h5"))));
    std::filesystem::remove(path("run.h5"));
  }
}

TEST_F(TiledCoarseLevelTest, LightNoiseSkipsItAsInCore) {
  const io::PointTable cloud = test::noisy_cube(4000, 43, 0.004);
  ASSERT_LT(estimate_noise(cloud.positions).ratio, 1.5);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 500}, 256));
  const SmoothParams params = with_coarse_level();
  const InCore ref = run_in_core(cloud, params);
  ASSERT_TRUE(ref.report.coarse_levels.empty());
  const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, {});
  EXPECT_TRUE(r.finished);
  EXPECT_TRUE(r.coarse_levels.empty());
  expect_identical(path("run.h5"), ref);
  EXPECT_FALSE(std::filesystem::exists(folder_of(path("run.h5"))));
}

TEST_F(TiledCoarseLevelTest, AFolderWithTheUsersFilesIsLeftAlone) {
  const io::PointTable cloud = heavy_noise_sphere();
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 500}, 256));
  const std::filesystem::path folder = folder_of(path("run.h5"));
  std::filesystem::create_directory(folder);
  std::ofstream(folder / "notes.txt") << "mine";
  OutOfCoreOptions options;
  options.resume = true;
  try {
    smooth_out_of_core(path("in.h5"), path("run.h5"), with_coarse_level(), options);
    ADD_FAILURE() << "a folder with the user's files was taken";
  } catch (const io::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("notes.txt"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(std::filesystem::exists(folder / "notes.txt"));
  // A plain file in its place is not a folder of the run's either.
  std::filesystem::remove_all(folder);
  std::ofstream(folder) << "mine";
  EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("run.h5"), with_coarse_level(), options), io::IoError);
  EXPECT_TRUE(std::filesystem::is_regular_file(folder));
}

}  // namespace
