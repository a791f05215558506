#include "pointfair/io/point_selection.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "pointfair/io/las.hpp"

namespace pointfair::io {
namespace {

// Six points: classes 2 2 5 6 5 2 (one not a whole number), returns 1/1 1/2 2/2 1/3 3/3 2/2.
PointTable six_points() {
  PointTable t;
  for (int i = 0; i < 6; ++i) t.positions.emplace_back(i, 0, 0);
  t.set("intensity", ScalarType::UInt16, {10, 11, 12, 13, 14, 15});
  t.set("classification", ScalarType::Float32, {2, 2, 5, 6, 5, 2.5});
  t.set("return_number", ScalarType::UInt8, {1, 1, 2, 1, 3, 2});
  t.set("number_of_returns", ScalarType::UInt8, {1, 2, 2, 3, 3, 2});
  return t;
}

using Rows = std::vector<std::size_t>;

TEST(PointSelection, ClassesAndReturnsPickTheirRows) {
  const PointTable t = six_points();
  PointSelection s;
  EXPECT_TRUE(s.all());
  EXPECT_EQ(selected_rows(t, s, "t"), (Rows{0, 1, 2, 3, 4, 5}));
  s.classes.set(2);
  EXPECT_EQ(selected_rows(t, s, "t"), (Rows{0, 1}));  // 2.5 is no code
  s.classes.set(5);
  EXPECT_EQ(selected_rows(t, s, "t"), (Rows{0, 1, 2, 4}));
  s.returns = ReturnSelection::Last;
  EXPECT_EQ(selected_rows(t, s, "t"), (Rows{0, 2, 4}));
  s.classes.reset();
  s.returns = ReturnSelection::First;
  EXPECT_EQ(selected_rows(t, s, "t"), (Rows{0, 1, 3}));
  s.returns = ReturnSelection::Only;
  EXPECT_EQ(selected_rows(t, s, "t"), (Rows{0}));
  s.returns = ReturnSelection::Numbers;
  s.return_numbers.set(2);
  s.return_numbers.set(3);
  EXPECT_EQ(selected_rows(t, s, "t"), (Rows{2, 4, 5}));
}

TEST(PointSelection, ClassColumnOfAnyCaseAndMissingFieldsNameTheFile) {
  PointTable t;
  t.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0)};
  PointSelection s;
  s.classes.set(3);
  try {
    selected_rows(t, s, "scan.ply");
    FAIL() << "no classification";
  } catch (const IoError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("scan.ply: has no classification", 0), 0u) << e.what();
  }
  t.set("Class", ScalarType::UInt8, {3, 4});
  EXPECT_EQ(selected_rows(t, s, "scan.ply"), (Rows{0}));
  t.text = TextLayout{};  // a headerless text file: its names are guesses
  EXPECT_THROW(selected_rows(t, s, "scan.xyz"), IoError);
  s.classes.reset();
  s.returns = ReturnSelection::Only;
  EXPECT_THROW(selected_rows(t, s, "scan.xyz"), IoError);
}

TEST(PointSelection, SelectAndSpliceRoundTripTheRows) {
  PointTable t = six_points();
  const Rows rows = {1, 4};
  PointTable part = select_rows(t, rows);
  ASSERT_EQ(part.size(), 2u);
  EXPECT_EQ(part.positions[1], Vec3(4, 0, 0));
  EXPECT_EQ(part.find("intensity")->values, (std::vector<double>{11, 14}));
  part.positions[0] = Vec3(9, 9, 9);
  part.find("intensity")->values[1] = 99;
  splice_rows(t, rows, part);
  EXPECT_EQ(t.positions[1], Vec3(9, 9, 9));
  EXPECT_EQ(t.positions[0], Vec3(0, 0, 0));
  EXPECT_EQ(t.find("intensity")->values, (std::vector<double>{10, 11, 12, 13, 99, 15}));
}

TEST(PointSelection, SelectedReaderReturnsTheSelectedPointsInOrderWhateverTheChunk) {
  PointTable t = six_points();
  t.find("classification")->values = {2, 5, 5, 2, 5, 2};
  t.find("classification")->type = ScalarType::UInt8;
  const auto file = std::filesystem::temp_directory_path() / "pointfair_selected_reader.las";
  write_las(file, t);
  PointSelection s;
  s.classes.set(5);
  for (const std::size_t chunk_points : {1u, 2u, 100u}) {
    const auto reader = open_selected_reader(open_las_reader(file), s);
    EXPECT_FALSE(reader->count().has_value());
    PointTable chunk;
    std::vector<double> xs, intensity;
    while (reader->read(chunk, chunk_points) > 0) {
      EXPECT_LE(chunk.size(), chunk_points);
      for (std::size_t i = 0; i < chunk.size(); ++i) {
        xs.push_back(chunk.positions[i].x());
        intensity.push_back(chunk.find("intensity")->values[i]);
      }
    }
    EXPECT_EQ(xs, (std::vector<double>{1, 2, 4}));
    EXPECT_EQ(intensity, (std::vector<double>{11, 12, 14}));
    EXPECT_EQ(reader->points_read(), 3u);
  }
  s.classes.reset();
  s.returns = ReturnSelection::Last;
  PointTable plain;
  plain.positions = t.positions;
  write_las(file, plain);  // return_number and number_of_returns are fields of every LAS format
  EXPECT_NO_THROW(open_selected_reader(open_las_reader(file), s));
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace pointfair::io
