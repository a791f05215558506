// Chunk readers and writers give exactly what the in-memory readers and writers give, for
// every encoding and chunk size; a writer that does not finish leaves no file.
#include "pointfair/io/point_chunks.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "io_test_util.hpp"
#include "pointfair/io/point_file.hpp"

namespace pointfair::io {
namespace {

namespace fs = std::filesystem;
using testing::expect_io_error;
using testing::read_file;
using testing::same_bits;
using testing::TempDir;
using testing::write_file;

PointTable sample_table(std::size_t count, ScalarType position_type) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> real(-50.0, 50.0);
  std::uniform_int_distribution<int> byte(0, 255);
  PointTable table;
  table.position_type = position_type;
  std::vector<double> red, weight, label;
  for (std::size_t i = 0; i < count; ++i) {
    Vec3 p(real(rng), real(rng), real(rng));
    if (position_type == ScalarType::Float32) p = p.unaryExpr([](double v) { return double(float(v)); });
    table.positions.push_back(p);
    red.push_back(byte(rng));
    weight.push_back(real(rng) / 3.0);
    label.push_back(std::round(real(rng)));
  }
  table.attributes.push_back({"red", ScalarType::UInt8, red});
  table.attributes.push_back({"weight", ScalarType::Float64, weight});
  table.attributes.push_back({"label", ScalarType::Int16, label});
  return table;
}

// Exact equality: same positions, names, types, values (to the bit) and order.
void expect_same(const PointTable& a, const PointTable& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.position_type, b.position_type);
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (int c = 0; c < 3; ++c) ASSERT_TRUE(same_bits(a.positions[i][c], b.positions[i][c])) << i;
  }
  ASSERT_EQ(a.attributes.size(), b.attributes.size());
  for (std::size_t k = 0; k < a.attributes.size(); ++k) {
    EXPECT_EQ(a.attributes[k].name, b.attributes[k].name);
    EXPECT_EQ(a.attributes[k].type, b.attributes[k].type);
    ASSERT_EQ(a.attributes[k].values.size(), b.attributes[k].values.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_TRUE(same_bits(a.attributes[k].values[i], b.attributes[k].values[i])) << k << " " << i;
    }
  }
}

// Every chunk appended: the table the chunk reader streams.
PointTable read_chunked(const fs::path& file, std::size_t chunk_points, std::vector<std::string>* warnings) {
  ReadOptions options;
  if (warnings) options.on_warning = [warnings](const std::string& w) { warnings->push_back(w); };
  const auto reader = open_point_reader(file, options);
  PointTable all = reader->schema();
  EXPECT_TRUE(all.positions.empty());
  PointTable chunk;
  std::size_t got = 0;
  while ((got = reader->read(chunk, chunk_points)) > 0) {
    EXPECT_LE(got, chunk_points);
    EXPECT_EQ(chunk.size(), got);
    all.positions.insert(all.positions.end(), chunk.positions.begin(), chunk.positions.end());
    for (std::size_t k = 0; k < chunk.attributes.size(); ++k) {
      EXPECT_EQ(chunk.attributes[k].values.size(), got);
      auto& to = all.attributes[k].values;
      to.insert(to.end(), chunk.attributes[k].values.begin(), chunk.attributes[k].values.end());
    }
  }
  EXPECT_EQ(reader->read(chunk, chunk_points), 0u) << "the end stays the end";
  EXPECT_EQ(reader->points_read(), all.size());
  if (reader->count()) {
    EXPECT_EQ(*reader->count(), all.size());
  }
  return all;
}

struct Encoding {
  const char* name;
  const char* file;
  PlyEncoding ply;
  ScalarType position_type;
};

class ChunkedFormats : public ::testing::TestWithParam<Encoding> {};

TEST_P(ChunkedFormats, ReaderGivesTheInMemoryTableForAnyChunkSize) {
  TempDir dir;
  const Encoding e = GetParam();
  const fs::path file = dir / e.file;
  write_points(file, sample_table(300, e.position_type), {.ply_encoding = e.ply, .input = {}});
  const PointTable whole = read_points(file);
  ASSERT_EQ(whole.size(), 300u);
  for (const std::size_t chunk : {std::size_t{1}, std::size_t{7}, std::size_t{300}, std::size_t{1} << 20}) {
    SCOPED_TRACE("chunk " + std::to_string(chunk));
    expect_same(read_chunked(file, chunk, nullptr), whole);
  }
}

TEST_P(ChunkedFormats, SkippedPointsLeaveTheRestAsReadFromThere) {
  TempDir dir;
  const Encoding e = GetParam();
  const fs::path file = dir / e.file;
  write_points(file, sample_table(300, e.position_type), {.ply_encoding = e.ply, .input = {}});
  const PointTable whole = read_points(file);
  for (const std::uint64_t first : {std::uint64_t{0}, std::uint64_t{1}, std::uint64_t{123}, std::uint64_t{298}}) {
    SCOPED_TRACE("skip " + std::to_string(first));
    const auto reader = open_point_reader(file);
    PointTable chunk;
    ASSERT_EQ(reader->read(chunk, 2), 2u);  // skipping also works after a read
    EXPECT_EQ(reader->skip(first), first);
    EXPECT_EQ(reader->points_read(), first + 2);
    const std::size_t rest = 300 - static_cast<std::size_t>(first) - 2;
    ASSERT_EQ(reader->read(chunk, 1000), rest);
    if (rest == 0) continue;
    for (std::size_t i = 0; i < chunk.size(); ++i) {
      ASSERT_TRUE(same_bits(chunk.positions[i].x(), whole.positions[first + 2 + i].x())) << i;
      for (std::size_t k = 0; k < chunk.attributes.size(); ++k)
        ASSERT_TRUE(same_bits(chunk.attributes[k].values[i], whole.attributes[k].values[first + 2 + i])) << k;
    }
  }
  // Past the end: only what is left, and what follows the points is handled as by reading.
  std::vector<std::string> warnings;
  ReadOptions options;
  options.on_warning = [&warnings](const std::string& w) { warnings.push_back(w); };
  std::vector<std::string> read_warnings;
  read_chunked(file, 1000, &read_warnings);
  const auto reader = open_point_reader(file, options);
  EXPECT_EQ(reader->skip(1000), 300u);
  PointTable chunk;
  EXPECT_EQ(reader->read(chunk, 10), 0u);
  EXPECT_EQ(warnings, read_warnings);
}

TEST_P(ChunkedFormats, WriterInChunksWritesTheSameBytes) {
  TempDir dir;
  const Encoding e = GetParam();
  const PointTable table = sample_table(100, e.position_type);
  const fs::path whole = dir / (std::string("whole_") + e.file);
  const fs::path chunked = dir / (std::string("chunked_") + e.file);
  write_points(whole, table, {.ply_encoding = e.ply, .input = {}});
  const auto writer = open_point_writer(chunked, table, table.size(), {.ply_encoding = e.ply, .input = {}});
  for (std::size_t first = 0; first < table.size(); first += 7) {
    PointTable chunk;
    chunk.position_type = table.position_type;
    const std::size_t last = std::min(table.size(), first + 7);
    chunk.positions.assign(table.positions.begin() + long(first), table.positions.begin() + long(last));
    for (const Attribute& a : table.attributes) {
      chunk.attributes.push_back({a.name, a.type, {a.values.begin() + long(first), a.values.begin() + long(last)}});
    }
    writer->write(chunk);
    EXPECT_FALSE(fs::exists(chunked)) << "the file appears only when finished";
  }
  writer->finish();
  EXPECT_EQ(writer->points_written(), table.size());
  EXPECT_EQ(read_file(chunked), read_file(whole));
}

TEST_P(ChunkedFormats, UnfinishedWriterLeavesNothingAndKeepsAnOldFile) {
  TempDir dir;
  const Encoding e = GetParam();
  const PointTable table = sample_table(20, e.position_type);
  const fs::path file = dir / e.file;
  write_file(file, "old contents");
  {
    const auto writer = open_point_writer(file, table, table.size() + 1, {.ply_encoding = e.ply, .input = {}});
    writer->write(table);
    expect_io_error([&] { writer->finish(); }, file, "of the");
  }
  EXPECT_EQ(read_file(file), "old contents");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{e.file}) << "no temporary left behind";
}

TEST_P(ChunkedFormats, WriterRejectsAChunkOfAnotherSchemaOrTooManyPoints) {
  TempDir dir;
  const Encoding e = GetParam();
  const PointTable table = sample_table(10, e.position_type);
  const fs::path file = dir / e.file;
  const auto writer = open_point_writer(file, table, 10, {.ply_encoding = e.ply, .input = {}});
  PointTable other = table;
  other.attributes.pop_back();
  expect_io_error([&] { writer->write(other); }, file, "attributes differ");
  writer->write(table);
  expect_io_error([&] { writer->write(table); }, file, "more points");
}

const Encoding kEncodings[] = {
    {"PlyAscii", "cloud.ply", PlyEncoding::Ascii, ScalarType::Float64},
    {"PlyBinaryLittleEndian", "cloud.ply", PlyEncoding::BinaryLittleEndian, ScalarType::Float32},
    {"PlyBinaryBigEndian", "cloud.ply", PlyEncoding::BinaryBigEndian, ScalarType::Float64},
    {"Xyz", "cloud.xyz", PlyEncoding::Ascii, ScalarType::Float64},
    {"Csv", "cloud.csv", PlyEncoding::Ascii, ScalarType::Float64},
    {"Las", "cloud.las", PlyEncoding::Ascii, ScalarType::Float64},
};

INSTANTIATE_TEST_SUITE_P(AllEncodings, ChunkedFormats, ::testing::ValuesIn(kEncodings),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(ChunkReader, PlyElementsAroundTheVerticesGiveTheSameTableAndWarnings) {
  TempDir dir;
  const fs::path file = dir / "faces.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement edge 1\nproperty int a\nproperty int b\n"
             "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
             "property uchar red\nelement face 2\nproperty list uchar int vertex_indices\n"
             "end_header\n0 1\n1 2 3 4\n5 6 7 8\n9 10 11 12\n3 0 1 2\n3 2 1 0\n");
  std::vector<std::string> whole_warnings;
  const PointTable whole =
      read_points(file, ReadOptions{.on_warning = [&](const std::string& w) { whole_warnings.push_back(w); }});
  ASSERT_EQ(whole_warnings.size(), 2u);
  for (const std::size_t chunk : {std::size_t{1}, std::size_t{2}, std::size_t{100}}) {
    std::vector<std::string> warnings;
    expect_same(read_chunked(file, chunk, &warnings), whole);
    EXPECT_EQ(warnings, whole_warnings);
  }
}

TEST(ChunkReader, XyzPointCountLineAndHeaderGiveTheSameTable) {
  TempDir dir;
  const fs::path file = dir / "cloud.pts";
  write_file(file, "# scan\n4\n\nX,Y,Z,intensity\n1,2,3,10\n4,5,6,11\n# mid\n7,8,9,12\n");
  std::vector<std::string> whole_warnings;
  const PointTable whole =
      read_points(file, ReadOptions{.on_warning = [&](const std::string& w) { whole_warnings.push_back(w); }});
  ASSERT_EQ(whole.size(), 3u);
  ASSERT_EQ(whole_warnings.size(), 1u) << "declared 4 points, has 3";
  for (const std::size_t chunk : {std::size_t{1}, std::size_t{2}, std::size_t{7}}) {
    std::vector<std::string> warnings;
    expect_same(read_chunked(file, chunk, &warnings), whole);
    EXPECT_EQ(warnings, whole_warnings);
  }
}

TEST(ChunkReader, LasChunksCarryTheQuantizationAndMetadata) {
  TempDir dir;
  const fs::path file = dir / "q.las";
  write_points(file, sample_table(40, ScalarType::Float64));
  const PointTable whole = read_points(file);
  ASSERT_TRUE(whole.quantization && whole.las);
  const auto reader = open_point_reader(file);
  ASSERT_TRUE(reader->schema().quantization && reader->schema().las);
  EXPECT_EQ(reader->schema().quantization->scale, whole.quantization->scale);
  EXPECT_EQ(reader->schema().quantization->offset, whole.quantization->offset);
  EXPECT_EQ(reader->schema().las->point_format, whole.las->point_format);
  EXPECT_EQ(*reader->count(), 40u);
  PointTable chunk;
  EXPECT_EQ(reader->read(chunk, 16), 16u);
  ASSERT_TRUE(chunk.quantization);
  EXPECT_EQ(chunk.quantization->scale, whole.quantization->scale);
}

TEST(ChunkWriter, LasWithAGridStreamsTheBytesOfWriteLas) {
  TempDir dir;
  write_points(dir / "source.las", sample_table(100, ScalarType::Float64));
  const PointTable table = read_points(dir / "source.las");  // has a quantization and LAS metadata
  ASSERT_TRUE(table.quantization);
  write_points(dir / "whole.las", table);
  const auto writer = open_point_writer(dir / "chunked.las", table, table.size());
  for (std::size_t first = 0; first < table.size(); first += 7) {
    PointTable chunk = table;
    const std::size_t last = std::min(table.size(), first + 7);
    chunk.positions.assign(table.positions.begin() + long(first), table.positions.begin() + long(last));
    for (std::size_t a = 0; a < table.attributes.size(); ++a) {
      chunk.attributes[a].values.assign(table.attributes[a].values.begin() + long(first),
                                        table.attributes[a].values.begin() + long(last));
    }
    writer->write(chunk);
  }
  EXPECT_FALSE(fs::exists(dir / "chunked.las"));
  writer->finish();
  EXPECT_EQ(read_file(dir / "chunked.las"), read_file(dir / "whole.las"));
}

TEST(ChunkReader, ErrorsComeFromTheChunkThatMeetsThem) {
  TempDir dir;
  const fs::path file = dir / "bad.xyz";
  write_file(file, "1 2 3\n4 5 6\n7 8\n");
  const auto reader = open_point_reader(file);
  PointTable chunk;
  EXPECT_EQ(reader->read(chunk, 2), 2u);
  expect_io_error([&] { reader->read(chunk, 2); }, file, "line 3: expected 3 columns, found 2");

  const fs::path ply = dir / "nan.ply";
  write_file(ply, "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                  "property double z\nend_header\n0 0 0\n1 1 1\n2 nan 2\n");
  const auto ply_reader = open_point_reader(ply);
  EXPECT_EQ(ply_reader->read(chunk, 2), 2u);
  expect_io_error([&] { ply_reader->read(chunk, 2); }, ply, "vertex 2 has a non-finite coordinate (nan) in line 10");
}

TEST(ChunkReader, TruncatedBinaryBodyIsFoundWhenTheReaderOpens) {
  TempDir dir;
  const fs::path file = dir / "cut.ply";
  write_points(file, sample_table(50, ScalarType::Float32));
  std::string bytes = read_file(file);
  bytes.resize(bytes.size() - 5);
  write_file(file, bytes);
  expect_io_error([&] { open_point_reader(file); }, file, "truncated binary body");
}

}  // namespace
}  // namespace pointfair::io
