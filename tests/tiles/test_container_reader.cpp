// A container read a chunk at a time gives exactly read_container's table (and
// read_run_attributes' results), in the input's order or the tile order, for any chunk size,
// whether the tiles' rows follow the input order (streamed import) or not (write_container).
#include "pointfair/tiles/container_reader.hpp"

#include "pointfair/io/point_file.hpp"
#include "pointfair/tiles/import.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

class ContainerReaderTest : public test::TempDirTest {};

struct Chunked {
  io::PointTable table;
  PointAttributes run;
};

Chunked read_chunked(const std::filesystem::path& file, const ContainerReaderOptions& options, std::size_t chunk_points) {
  ContainerChunkReader reader(file, options);
  Chunked all;
  all.table = reader.schema();
  io::PointTable chunk;
  while (const std::size_t got = reader.read(chunk, chunk_points)) {
    EXPECT_LE(got, chunk_points);
    all.table.positions.insert(all.table.positions.end(), chunk.positions.begin(), chunk.positions.end());
    for (std::size_t a = 0; a < chunk.attributes.size(); ++a) {
      auto& to = all.table.attributes[a].values;
      to.insert(to.end(), chunk.attributes[a].values.begin(), chunk.attributes[a].values.end());
    }
    if (options.run_attributes) {
      const PointAttributes& r = reader.run_attributes();
      EXPECT_EQ(r.k1.size(), got);
      all.run.normal.insert(all.run.normal.end(), r.normal.begin(), r.normal.end());
      all.run.k1.insert(all.run.k1.end(), r.k1.begin(), r.k1.end());
      all.run.laplacian_norm.insert(all.run.laplacian_norm.end(), r.laplacian_norm.begin(), r.laplacian_norm.end());
      all.run.feature.insert(all.run.feature.end(), r.feature.begin(), r.feature.end());
    }
  }
  EXPECT_EQ(reader.points_read(), *reader.count());
  return all;
}

void expect_same(const io::PointTable& a, const io::PointTable& b) {
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.position_type, b.position_type);
  ASSERT_EQ(a.attributes.size(), b.attributes.size());
  for (std::size_t k = 0; k < a.attributes.size(); ++k) {
    EXPECT_EQ(a.attributes[k].name, b.attributes[k].name);
    EXPECT_EQ(a.attributes[k].type, b.attributes[k].type);
    EXPECT_EQ(a.attributes[k].values, b.attributes[k].values);
  }
}

TEST_F(ContainerReaderTest, ChunksGiveTheWholeTableInEitherOrder) {
  const io::PointTable cloud = test::noisy_cube(1200, 41);
  io::write_points(path("in.ply"), cloud);
  write_container(path("kd.h5"), cloud, test::tiled({.max_tile_points = 150}, 64));
  StreamImportOptions streamed;
  streamed.container = test::tiled({.max_tile_points = 150}, 64);
  import_points(path("in.ply"), path("streamed.h5"), streamed);
  for (const char* name : {"kd.h5", "streamed.h5"}) {
    for (const bool original : {true, false}) {
      const io::PointTable whole = read_container(path(name), {.original_order = original, .result_positions = true});
      for (const std::size_t chunk : {std::size_t{1}, std::size_t{7}, std::size_t{1000}, std::size_t{1} << 20}) {
        SCOPED_TRACE(std::string(name) + (original ? " input order" : " tile order") + ", chunk " +
                     std::to_string(chunk));
        expect_same(read_chunked(path(name), {.original_order = original}, chunk).table, whole);
      }
    }
  }
}

TEST_F(ContainerReaderTest, RunResultsComeWithTheirPoints) {
  const io::PointTable cloud = test::noisy_cube(2000, 42);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 300}));
  SmoothParams params;
  params.finish.reset();  // the flow alone
  params.steps = 2;
  smooth_out_of_core(path("in.h5"), path("run.h5"), params);
  const io::PointTable whole = read_container(path("run.h5"));
  const PointAttributes results = read_run_attributes(path("run.h5"));
  for (const std::size_t chunk : {std::size_t{7}, std::size_t{500}}) {
    const Chunked c = read_chunked(path("run.h5"), {.run_attributes = true}, chunk);
    expect_same(c.table, whole);
    EXPECT_EQ(c.run.normal, results.normal);
    EXPECT_EQ(c.run.k1, results.k1);
    EXPECT_EQ(c.run.laplacian_norm, results.laplacian_norm);
    EXPECT_EQ(c.run.feature, results.feature);
  }
  // The input positions on request; results of a file without a run are an error.
  expect_same(read_chunked(path("run.h5"), {.result_positions = false}, 100).table,
              read_container(path("run.h5"), {.original_order = true, .result_positions = false}));
  EXPECT_THROW(ContainerChunkReader(path("in.h5"), {.run_attributes = true}), io::IoError);
}

TEST_F(ContainerReaderTest, DuplicateOriginalIndexIsAnIoError) {
  const io::PointTable cloud = test::noisy_cube(500, 43);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 100}));
  {
    h5::File f = h5::File::open(path("in.h5"), true);
    h5::Dataset orig = f.dataset(layout::original_index);
    std::uint64_t first = 0;
    orig.read_rows(0, 1, &first);
    orig.write_rows(1, 1, &first);
  }
  for (const std::size_t chunk : {std::size_t{10}, std::size_t{1000}}) {
    ContainerChunkReader reader(path("in.h5"));
    io::PointTable t;
    EXPECT_THROW(
        {
          while (reader.read(t, chunk) > 0) {
          }
        },
        io::IoError);
  }
}

}  // namespace
