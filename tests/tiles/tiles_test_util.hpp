#pragma once
// Helpers of the out-of-core tests: temporary directories and small noisy clouds.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "pointfair/io/point_table.hpp"
#include "pointfair/shapes.hpp"
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

/// Import options with these tiles and chunk rows.
inline tiles::ImportOptions tiled(const tiles::TilingParams& tiling, std::uint64_t chunk_rows = 65536) {
  tiles::ImportOptions o;
  o.tiling = tiling;
  o.chunk_rows = chunk_rows;
  return o;
}

}  // namespace pointfair::test
