// libFuzzer target: the PLY point reader (ascii, binary little and big endian) and the PLY
// mesh reader on arbitrary bytes. Expected outcomes: a table or an IoError; anything else
// (a crash, a sanitizer report, an allocation over libFuzzer's limit) is a finding.
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "fuzz_input.hpp"
#include "pointfair/io/mesh.hpp"
#include "pointfair/io/ply.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pointfair;
  const fuzz::MemoryFile file(data, size);
  try {
    const io::PointTable table = io::read_ply(file.path());
    for (const Vec3& p : table.positions)
      if (!p.allFinite()) std::abort();  // the reader promises finite coordinates
    for (const io::Attribute& a : table.attributes)
      if (a.values.size() != table.size()) std::abort();
  } catch (const io::IoError&) {
  }
  try {
    const TriangleMesh mesh = io::read_ply_mesh(file.path());
    for (const auto& t : mesh.triangles)
      for (const auto i : t)
        if (static_cast<std::size_t>(i) >= mesh.vertices.size()) std::abort();
  } catch (const io::IoError&) {
  }
  return 0;
}
