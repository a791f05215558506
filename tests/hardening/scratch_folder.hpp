#pragma once
// A test fixture with its own fresh folder under the system's temporary directory, removed
// after each test, and the files the hardening tests write into it byte for byte.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "pointfair/io/point_file.hpp"

namespace pointfair::testing_hardening {

class ScratchFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = std::filesystem::temp_directory_path() / ("pointfair_hardening_" + std::to_string(rd()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::filesystem::path write_bytes(const std::string& name, const std::string& bytes) {
    const std::filesystem::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }
  // What reading `file` throws as an IoError ("" when it reads).
  static std::string read_error(const std::filesystem::path& file) {
    try {
      io::read_points(file);
    } catch (const io::IoError& e) {
      return e.what();
    }
    return "";
  }
  std::filesystem::path dir_;
};

}  // namespace pointfair::testing_hardening
