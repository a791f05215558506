#include <gtest/gtest.h>

#include <vector>

#include "pointfair/io/attribute_roles.hpp"

namespace pointfair::io {
namespace {

TEST(AttributeRoles, NormalsAreFoundByTheirUsualNamesInAnyCase) {
  PointTable table;
  table.positions = {Vec3(0, 0, 0)};
  table.set("intensity", ScalarType::UInt16, {7});
  table.set("Normal_X", ScalarType::Float32, {0});
  table.set("normal_y", ScalarType::Float32, {0});
  table.set("NORMAL_Z", ScalarType::Float64, {1});
  ASSERT_EQ(normal_columns(table).size(), 1u);
  EXPECT_EQ(normal_columns(table)[0], (std::array<std::size_t, 3>{1, 2, 3}));
  table.find("normal_y")->type = ScalarType::Int8;  // integer "normals": not ours to touch
  EXPECT_TRUE(normal_columns(table).empty());
}

TEST(AttributeRoles, GuessedNamesOfAHeaderlessTextFileAreNotNormals) {
  PointTable table;
  table.positions = {Vec3(0, 0, 0)};
  for (const char* name : {"nx", "ny", "nz"}) table.set(name, ScalarType::Float64, {255});
  EXPECT_EQ(normal_columns(table).size(), 1u);
  table.text = TextLayout{};  // header = false
  EXPECT_TRUE(normal_columns(table).empty());
  table.text->header = true;
  EXPECT_EQ(normal_columns(table).size(), 1u);
}

TEST(AttributeRoles, RefreshedNormalsKeepTheOldOrientationAndTypes) {
  PointTable table;
  table.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0)};
  table.set("nx", ScalarType::Float32, {0.1, 0.1});
  table.set("ny", ScalarType::Float32, {0.0, 0.0});
  table.set("nz", ScalarType::Float32, {-0.99, 0.99});
  const std::vector<Vec3> normals = {Vec3(0, 0, 1), Vec3(0, 0, 1)};
  refresh_normals(table, normals);
  EXPECT_EQ(table.find("nx")->values, (std::vector<double>{0, 0}));
  EXPECT_EQ(table.find("nz")->values, (std::vector<double>{-1, 1}));
  EXPECT_EQ(table.find("nz")->type, ScalarType::Float32);
}

TEST(AttributeRoles, ClassificationIsClassificationOrClassInAnyCase) {
  PointTable table;
  table.set("classes", ScalarType::UInt8, {});
  EXPECT_EQ(classification_column(table), nullptr);
  table.set("Class", ScalarType::UInt8, {});
  ASSERT_NE(classification_column(table), nullptr);
  EXPECT_EQ(classification_column(table)->name, "Class");
  table.set("CLASSIFICATION", ScalarType::UInt8, {});
  EXPECT_EQ(classification_column(table)->name, "CLASSIFICATION");
  table.text = TextLayout{};  // no header line: the names are guesses
  EXPECT_EQ(classification_column(table), nullptr);
}

TEST(AttributeRoles, ColourIsRedGreenBlueOrRGB) {
  PointTable table;
  EXPECT_FALSE(has_colour(table));
  for (const char* name : {"R", "G"}) table.set(name, ScalarType::UInt8, {});
  EXPECT_FALSE(has_colour(table));
  table.set("b", ScalarType::UInt8, {});
  EXPECT_TRUE(has_colour(table));
}

}  // namespace
}  // namespace pointfair::io
