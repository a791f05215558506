// libFuzzer target: the LAS reader (versions 1.0-1.4, point formats 0-10, VLRs, EVLRs,
// extra bytes, and LAZ: the corpus has LAZ files of formats 1 and 7) on arbitrary bytes. Expected outcomes: a table or an IoError; anything else
// (a crash, a sanitizer report, an allocation over libFuzzer's limit) is a finding.
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "fuzz_input.hpp"
#include "pointfair/io/las.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pointfair;
  const fuzz::MemoryFile file(data, size);
  try {
    const io::PointTable table = io::read_las(file.path());
    for (const Vec3& p : table.positions)
      if (!p.allFinite()) std::abort();  // the reader promises finite coordinates
    for (const io::Attribute& a : table.attributes)
      if (a.values.size() != table.size()) std::abort();
    if (!table.quantization || !table.las) std::abort();  // a LAS source always has both
    // Records never exceed what the file held.
    std::size_t bytes = 0;
    for (const io::LasRecord& r : table.las->records) bytes += r.data.size();
    if (bytes > size) std::abort();
  } catch (const io::IoError&) {
  }
  return 0;
}
