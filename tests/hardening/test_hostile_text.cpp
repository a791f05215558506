// Text dialects the readers meet: CR-only line endings, a UTF-8 byte-order mark, UTF-16, and
// decimal commas with ';' delimiters. Each is read correctly or refused with the file, the line
// and the reason; never read as other numbers.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "pointfair/io/point_file.hpp"
#include "scratch_folder.hpp"

namespace fs = std::filesystem;
using namespace pointfair;

namespace {

class HostileText : public testing_hardening::ScratchFolder {};

TEST_F(HostileText, CrOnlyLineEndingsAreRefusedNotReadAsOneLine) {
  for (const std::string name : {"a.xyz", "a.csv", "a.txt"}) {
    const std::string text = name == "a.csv" ? "x,y,z,i\r0,0,0,1\r1,0,0,2\r0,1,0,3\r" : "x y z i\r0 0 0 1\r1 0 0 2\r";
    const std::string error = read_error(write_bytes(name, text));
    EXPECT_NE(error.find(name + ": line 1: carriage return inside a line (CR-only line endings?)"), std::string::npos)
        << error;
  }
  const std::string ply = read_error(write_bytes(
      "a.ply", "ply\rformat ascii 1.0\relement vertex 1\rproperty float x\rproperty float y\rproperty float z\r"
               "end_header\r0 0 0\r"));
  EXPECT_NE(ply.find("a.ply: line 1: carriage return inside a line"), std::string::npos) << ply;
  // CRLF is read as before.
  const io::PointTable t = io::read_points(write_bytes("b.xyz", "x y z i\r\n0 0 0 1\r\n1 0 0 2\r\n"));
  EXPECT_EQ(t.size(), 2u);
}

TEST_F(HostileText, AUtf8ByteOrderMarkIsSkipped) {
  const io::PointTable t = io::read_points(write_bytes("bom.csv", "\xEF\xBB\xBFx,y,z,intensity\n1,2,3,4\n5,6,7,8\n"));
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.positions[1], Vec3(5, 6, 7));
  ASSERT_NE(t.find("intensity"), nullptr);
  EXPECT_EQ(t.find("intensity")->values[0], 4.0);
  // Headerless too: the mark is not part of the first number.
  const io::PointTable u = io::read_points(write_bytes("bom.xyz", "\xEF\xBB\xBF" "1 2 3\n4 5 6\n"));
  ASSERT_EQ(u.size(), 2u);
  EXPECT_EQ(u.positions[0], Vec3(1, 2, 3));
  // UTF-16 is refused, with a BOM in a PLY named.
  const std::string utf16 = read_error(write_bytes("w.xyz", std::string("\xFF\xFE" "1\0 \0" "2\0", 8)));
  EXPECT_NE(utf16.find("w.xyz: UTF-16 text is not read"), std::string::npos) << utf16;
  const std::string ply = read_error(write_bytes("bom.ply", "\xEF\xBB\xBFply\nformat ascii 1.0\n"));
  EXPECT_NE(ply.find("bom.ply: line 1: a UTF-8 byte-order mark"), std::string::npos) << ply;
}

TEST_F(HostileText, DecimalCommasAreRefusedNotReadAsMoreColumns) {
  // "1,5;2,25;3,0" was split on both characters: six numbers, x = 1, y = 5, z = 2.
  for (const std::string text : {"1,5;2,25;3,0\n4,5;5,5;6,5\n", "x;y;z\n1,5;2,25;3,0\n", "x;y;z;i\n1;2;3;0,5\n"}) {
    SCOPED_TRACE(text);
    const std::string error = read_error(write_bytes("eu.csv", text));
    EXPECT_NE(error.find("eu.csv: line "), std::string::npos) << error;
    EXPECT_NE(error.find("decimal commas are not read"), std::string::npos) << error;
  }
  // ';' delimiters with decimal points read.
  const io::PointTable t = io::read_points(write_bytes("ok.csv", "x;y;z\n1.5;2.25;3\n"));
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(t.positions[0], Vec3(1.5, 2.25, 3));
}

}  // namespace
