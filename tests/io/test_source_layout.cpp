#include <gtest/gtest.h>

#include <string>

#include "pointfair/io/source_layout.hpp"

namespace pointfair::io {
namespace {

TEST(SourceLayout, TextAndPlyLayoutsSurviveTheirEncoding) {
  PointTable table;
  table.text = TextLayout{.header = true, .separator = ", ", .line_end = "\r\n", .count_line = true, .columns = {}};
  table.text->columns = {{"x", 0, "\"X\"", 3}, {"Point Source", -1, "Point Source", 0}, {"pct%", -1, "", -1}};
  table.ply = PlyLayout{.encoding = PlyEncoding::BinaryBigEndian,
                        .header_lines = {"comment two  spaces", "obj_info a\tb"},
                        .properties = {"red", "x"}};
  PointTable back;
  ASSERT_TRUE(decode_source_layout(encode_source_layout(table), back));
  ASSERT_TRUE(back.text.has_value());
  EXPECT_TRUE(back.text->header);
  EXPECT_TRUE(back.text->count_line);
  EXPECT_EQ(back.text->separator, ", ");
  EXPECT_EQ(back.text->line_end, "\r\n");
  ASSERT_EQ(back.text->columns.size(), 3u);
  EXPECT_EQ(back.text->columns[0].header, "\"X\"");
  EXPECT_EQ(back.text->columns[0].axis, 0);
  EXPECT_EQ(back.text->columns[0].decimals, 3);
  EXPECT_EQ(back.text->columns[1].name, "Point Source");
  EXPECT_EQ(back.text->columns[2].name, "pct%");
  EXPECT_EQ(back.text->columns[2].header, "");
  EXPECT_EQ(back.text->columns[2].decimals, -1);
  ASSERT_TRUE(back.ply.has_value());
  EXPECT_EQ(back.ply->encoding, PlyEncoding::BinaryBigEndian);
  EXPECT_EQ(back.ply->header_lines, table.ply->header_lines);
  EXPECT_EQ(back.ply->properties, table.ply->properties);
}

TEST(SourceLayout, NothingToKeepIsEmptyAndForeignTextIsRefused) {
  EXPECT_EQ(encode_source_layout(PointTable{}), "");
  PointTable table;
  EXPECT_TRUE(decode_source_layout("", table));
  EXPECT_FALSE(table.text.has_value());
  EXPECT_FALSE(decode_source_layout("text 1 0 =%2 =\n", table));      // a cut escape
  EXPECT_FALSE(decode_source_layout("column 0 3 =x =x\n", table));    // a column before "text"
  EXPECT_FALSE(decode_source_layout("ply 7\n", table));               // no such encoding
  EXPECT_FALSE(decode_source_layout("ply 0", table));                 // no line end
  EXPECT_FALSE(table.ply.has_value());
}

}  // namespace
}  // namespace pointfair::io
