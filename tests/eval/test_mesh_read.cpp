#include "pointfair/io/mesh.hpp"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "pointfair/shapes/shapes.hpp"

namespace pointfair::io {
namespace {

class MeshRead : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("pointfair_mesh_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path write(const std::string& name, const std::string& text) {
    const auto p = dir_ / name;
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
  std::filesystem::path dir_;
};

TEST_F(MeshRead, OffWithCommentsAndAQuad) {
  const auto p = write("q.off", "OFF\n# a unit square and a triangle\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n"
                                "4 0 1 2 3\n3 0 1 4\n");
  const TriangleMesh m = read_mesh(p);
  ASSERT_EQ(m.vertices.size(), 5u);
  ASSERT_EQ(m.triangles.size(), 3u);  // the quad becomes two triangles
  EXPECT_EQ(m.triangles[1], (std::array<Index, 3>{0, 2, 3}));
  EXPECT_EQ(m.vertices[4], Vec3(0, 0, 1));
}

TEST_F(MeshRead, OffErrorsNameTheProblem) {
  EXPECT_THROW(read_off_mesh(write("a.off", "PLY\n")), IoError);
  EXPECT_THROW(read_off_mesh(write("b.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")), IoError);
  EXPECT_THROW(read_off_mesh(write("c.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n")), IoError);
  try {
    read_off_mesh(write("d.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"));
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos);
  }
}

TEST_F(MeshRead, PlyAsciiAndBinary) {
  const std::string header_tail =
      "element vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\n"
      "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
  const auto a = write("a.ply", "ply\nformat ascii 1.0\n" + header_tail +
                                    "0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n3 0 1 2\n3 0 2 3\n");
  const TriangleMesh ma = read_mesh(a);
  ASSERT_EQ(ma.triangles.size(), 2u);
  EXPECT_EQ(ma.vertices[2], Vec3(1, 1, 0));

  std::string body;
  auto put = [&](const void* p, std::size_t n) { body.append(static_cast<const char*>(p), n); };
  const float v[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  for (int i = 0; i < 4; ++i) {
    put(v[i], 12);
    const unsigned char red = 9;
    put(&red, 1);
  }
  const int faces[2][3] = {{0, 1, 2}, {0, 2, 3}};
  for (const auto& f : faces) {
    const unsigned char n = 3;
    put(&n, 1);
    put(f, 12);
  }
  const auto b = write("b.ply", "ply\nformat binary_little_endian 1.0\n" + header_tail + body);
  const TriangleMesh mb = read_mesh(b);
  EXPECT_EQ(mb.vertices, ma.vertices);
  EXPECT_EQ(mb.triangles, ma.triangles);
  EXPECT_THROW(read_ply_mesh(write("c.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                            "property float y\nproperty float z\nend_header\n0 0 0\n")),
               IoError);
}

TEST_F(MeshRead, OffRoundTrip) {
  const TriangleMesh m = truncated_octahedron_mesh();
  write_off_mesh(dir_ / "t.off", m);
  const TriangleMesh back = read_mesh(dir_ / "t.off");
  EXPECT_EQ(back.vertices, m.vertices);
  EXPECT_EQ(back.triangles, m.triangles);
}

}  // namespace
}  // namespace pointfair::io
