#pragma once
// Helpers of the out-of-core tests: temporary directories and small noisy clouds.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/finish/quadric_projection.hpp"
#include "pointfair/io/point_table.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/tiles/container.hpp"

namespace pointfair::test {

/// A fresh directory under the system's temporary directory, removed with the fixture.
class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = std::filesystem::temp_directory_path() / ("pointfair_tiles_" + std::to_string(rd()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path path(const std::string& name) const { return dir_ / name; }

  std::filesystem::path dir_;
};

/// A TempDirTest whose tests may set the thread count: each gets the default back after it.
class ThreadsTempDirTest : public TempDirTest {
 protected:
  void TearDown() override {
    set_thread_count(0);
    TempDirTest::TearDown();
  }
};

/// A noisy cube surface (sharp edges and corners) with two extra attributes.
inline io::PointTable noisy_cube(std::size_t count, std::uint64_t seed, double sigma = 0.01) {
  SurfaceSamples s = sample_mesh(cube_mesh(), count, seed);
  add_noise(s.points, sigma, seed + 1);
  io::PointTable t;
  t.positions = s.points;
  std::vector<double> intensity(count), label(count);
  for (std::size_t i = 0; i < count; ++i) {
    intensity[i] = static_cast<double>((i * 7919) % 65536);
    label[i] = static_cast<double>(static_cast<int>(i % 5) - 2);
  }
  t.attributes.push_back({"intensity", io::ScalarType::UInt16, intensity});
  t.attributes.push_back({"label", io::ScalarType::Int8, label});
  return t;
}

/// The reference of the out-of-core tests: smooth() and compute_attributes() in memory.
struct InCore {
  std::vector<Vec3> positions;
  PointAttributes attributes;
  SmoothReport report;
};

/// The flow's parameters with `steps` steps, the rest their defaults.
inline SmoothParams few_steps(int steps = 3) {
  SmoothParams p;
  p.finish.reset();  // the flow alone
  p.steps = steps;
  return p;
}

/// `params` with the finish `q` (and their placement).
inline SmoothParams finishing(SmoothParams params, const QuadricProjectionParams& q) {
  params.finish = q;
  return params;
}

/// As the command runs it: smooth() (the flow and, with params.finish, the finish and the
/// placement), and the attributes of the result over the flow's last lists with its last lambda.
inline InCore run_in_core(const io::PointTable& table, const SmoothParams& params) {
  InCore r;
  r.positions = table.positions;
  r.report = smooth(r.positions, params);
  r.attributes = compute_attributes(r.positions, r.report.neighborhoods, params.flow, r.report.lambda);
  return r;
}

inline void expect_identical(const std::filesystem::path& run, const InCore& ref) {
  const io::PointTable out = tiles::read_container(run);
  ASSERT_EQ(out.size(), ref.positions.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < out.size(); ++i) differ += out.positions[i] != ref.positions[i];
  EXPECT_EQ(differ, 0u) << "positions differ from the in-core run";
  const PointAttributes a = tiles::read_run_attributes(run);
  std::size_t bad = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    bad += a.normal[i] != ref.attributes.normal[i] || a.d1[i] != ref.attributes.d1[i] ||
           a.d2[i] != ref.attributes.d2[i] || a.k1[i] != ref.attributes.k1[i] || a.k2[i] != ref.attributes.k2[i] ||
           a.mean_curvature[i] != ref.attributes.mean_curvature[i] ||
           a.laplacian_norm[i] != ref.attributes.laplacian_norm[i] || a.feature[i] != ref.attributes.feature[i];
  }
  EXPECT_EQ(bad, 0u) << "attributes differ from the in-core run";
  EXPECT_EQ(a.degenerate, ref.attributes.degenerate);
}

/// Import options with these tiles and chunk rows.
inline tiles::ImportOptions tiled(const tiles::TilingParams& tiling, std::uint64_t chunk_rows = 65536) {
  tiles::ImportOptions o;
  o.tiling = tiling;
  o.chunk_rows = chunk_rows;
  return o;
}

}  // namespace pointfair::test
