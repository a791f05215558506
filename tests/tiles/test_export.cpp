// The streaming export (export.hpp): a container's points come back as the input in its order,
// chunk by chunk whatever the budget, with the columns the caller's hook adds.
#include "pointfair/tiles/export.hpp"

#include <string>

#include "pointfair/io/point_file.hpp"
#include "pointfair/tiles/import.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

class ExportTest : public test::TempDirTest {};

TEST_F(ExportTest, ThePointsComeBackInTheInputOrderWithTheHooksColumns) {
  const io::PointTable cloud = test::noisy_cube(3000, 5);
  io::write_points(path("cloud.ply"), cloud);
  const io::PointTable input = io::read_points(path("cloud.ply"));
  StreamImportOptions import;
  import.container.tiling.max_tile_points = 64;
  import.memory_budget = kMinImportBudget;
  import_points(path("cloud.ply"), path("cloud.h5"), import);

  StreamExportOptions options;
  options.memory_budget = 1;  // the least chunk (1024 points): three of them
  std::size_t calls = 0;
  options.columns = [&calls](io::PointTable& chunk, const PointAttributes& results) {
    EXPECT_TRUE(results.normal.empty());
    chunk.set("tag", io::ScalarType::UInt8, std::vector<double>(chunk.size(), 7.0));
    ++calls;
  };
  EXPECT_EQ(export_points(path("cloud.h5"), path("out.ply"), options), input.size());
  EXPECT_GT(calls, 2u);
  const io::PointTable out = io::read_points(path("out.ply"));
  ASSERT_EQ(out.size(), input.size());
  EXPECT_EQ(out.positions, input.positions);
  ASSERT_NE(out.find("tag"), nullptr);
}

}  // namespace
