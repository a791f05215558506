// The scan container: what goes in comes out, in the input's order or the tile order.
#include "pointfair/tiles/container.hpp"

#include <fstream>
#include <random>

#include "pointfair/io/las.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

class ContainerTest : public test::TempDirTest {};

TEST_F(ContainerTest, RoundTripKeepsOrderAttributesAndTypes) {
  io::PointTable in = test::noisy_cube(3000, 5);
  in.position_type = io::ScalarType::Float32;
  const auto file = path("c.h5");
  ImportOptions options = test::tiled({.max_tile_points = 100}, 64);
  options.source_name = "cube.ply";
  write_container(file, in, options);
  const io::PointTable out = read_container(file);
  ASSERT_EQ(out.size(), in.size());
  EXPECT_EQ(out.positions, in.positions);
  EXPECT_EQ(out.position_type, io::ScalarType::Float32);
  ASSERT_EQ(out.attributes.size(), 2u);
  for (std::size_t a = 0; a < 2; ++a) {
    EXPECT_EQ(out.attributes[a].name, in.attributes[a].name);
    EXPECT_EQ(out.attributes[a].type, in.attributes[a].type);
    EXPECT_EQ(out.attributes[a].values, in.attributes[a].values);
  }
  const h5::File f = h5::File::open(file, false);
  const TileTable tiles = read_tile_table(f);
  EXPECT_GE(tiles.size(), 30u);
  EXPECT_EQ(f.string_attribute("/", "pointfair_format"), "pointfair-scan");
  EXPECT_EQ(f.string_attribute("/", "source_name"), "cube.ply");
  EXPECT_EQ(f.int_attribute("/", "point_count"), 3000);
  EXPECT_FALSE(has_finished_run(f));
  // Tile order: rows grouped by tile, original_index maps them back.
  const io::PointTable tiled = read_container(file, {.original_order = false});
  const auto order = f.dataset(layout::original_index).read_all<std::uint64_t>();
  for (std::size_t r = 0; r < order.size(); ++r) ASSERT_EQ(tiled.positions[r], in.positions[order[r]]);
}

// import LAS -> export LAS: the same integers, point format and fields (the container keeps
// the LAS scale, offset and format).
TEST_F(ContainerTest, LasThroughTheContainerKeepsIntegersAndFormat) {
  io::PointTable cloud = test::noisy_cube(500, 7);
  cloud.attributes.clear();
  std::mt19937 rng(3);
  std::vector<double> classification(cloud.size()), intensity(cloud.size()), gps(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    classification[i] = static_cast<double>(rng() % 32);
    intensity[i] = static_cast<double>(rng() % 65536);
    gps[i] = 1e5 + 1e-3 * static_cast<double>(rng() % 100000);
  }
  cloud.set("classification", io::ScalarType::UInt8, classification);
  cloud.set("intensity", io::ScalarType::UInt16, intensity);
  cloud.set("gps_time", io::ScalarType::Float64, gps);
  cloud.las = io::LasMetadata{};
  cloud.las->version_minor = 2;
  cloud.las->point_format = 1;
  cloud.quantization = io::PositionQuantization{Vec3(0.0025, 0.001, 0.01), Vec3(-3, 17, 1000)};
  io::write_las(path("in.las"), cloud);
  const io::PointTable in = io::read_las(path("in.las"));

  write_container(path("c.h5"), in, test::tiled({.max_tile_points = 64}, 32));
  const io::PointTable out = read_container(path("c.h5"));
  ASSERT_TRUE(out.quantization.has_value());
  EXPECT_EQ(out.quantization->scale, in.quantization->scale);
  EXPECT_EQ(out.quantization->offset, in.quantization->offset);
  ASSERT_TRUE(out.las.has_value());
  EXPECT_EQ(out.las->point_format, 1);
  EXPECT_EQ(out.las->version_minor, 2);
  io::write_las(path("out.las"), out);
  const io::PointTable back = io::read_las(path("out.las"));
  EXPECT_EQ(back.positions, in.positions);
  ASSERT_EQ(back.attributes.size(), in.attributes.size());
  for (const io::Attribute& a : in.attributes) {
    ASSERT_NE(back.find(a.name), nullptr) << a.name;
    EXPECT_EQ(back.find(a.name)->values, a.values) << a.name;
    EXPECT_EQ(back.find(a.name)->type, a.type) << a.name;
  }
  // The VLRs and point records are byte-identical.
  const auto records = [](const std::filesystem::path& p, std::size_t skip) {
    std::ifstream f(p, std::ios::binary);
    std::string s((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    return s.substr(skip);
  };
  EXPECT_EQ(records(path("out.las"), 227), records(path("in.las"), 227));
}

TEST_F(ContainerTest, EmptyCloud) {
  const auto file = path("empty.h5");
  write_container(file, io::PointTable{});
  EXPECT_EQ(read_container(file).size(), 0u);
}

TEST_F(ContainerTest, BadInputsAreIoErrors) {
  io::PointTable in = test::noisy_cube(10, 1);
  in.attributes[0].values.pop_back();
  EXPECT_THROW(write_container(path("bad.h5"), in), io::IoError);
  EXPECT_FALSE(std::filesystem::exists(path("bad.h5")));
  {
    h5::File f = h5::File::create(path("plain.h5"));
    f.create_dataset("/x", h5::Type::Float64, 1, 0);
  }
  try {
    read_container(path("plain.h5"));
    FAIL();
  } catch (const io::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("not a pointfair container"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_run_attributes(path("plain.h5")), io::IoError);
}

}  // namespace
