// libFuzzer target: opening the HDF5 scan container (pointfair::tiles). The bytes do not
// become the HDF5 file itself (that would fuzz libhdf5's parser, which is not ours and not
// instrumented); they describe a structurally valid HDF5 file whose pointfair content is
// arbitrary: missing or wrong format markers, shapes that disagree, tile offsets out of order
// or out of range, original indices that are no permutation, non-finite positions, attribute
// datasets of the wrong length, a run record naming a missing dataset. Then the file is read
// (read_container in both orders, read_run_attributes) and a one-step out-of-core run is
// started on it. Expected outcomes: a result, an IoError or a ParamError.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "pointfair/common/params_error.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/hdf5_file.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"

namespace {

using namespace pointfair;
namespace fs = std::filesystem;
namespace h5 = tiles::h5;

class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t u8() { return at_ < size_ ? data_[at_++] : 0; }
  std::uint64_t below(std::uint64_t n) { return n == 0 ? 0 : u8() % n; }
  double real() {
    const std::uint8_t mode = u8();
    if (mode < 200) return static_cast<double>(static_cast<std::int8_t>(u8())) / 8.0;
    std::uint64_t bits = 0;
    for (int i = 0; i < 8; ++i) bits = (bits << 8) | u8();
    double v = 0;
    std::memcpy(&v, &bits, sizeof v);  // any double: NaN, inf, subnormal
    return v;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

fs::path scratch(const char* name) {
  return fs::temp_directory_path() / ("pointfair_fuzz_" + std::to_string(::getpid()) + "_" + name);
}

void build(const fs::path& path, Bytes& in) {
  const std::uint8_t flags = in.u8();
  const std::uint64_t n = in.below(40);
  const std::uint64_t tiles = in.below(5);
  h5::File f = h5::File::create(path);
  if (!(flags & 1)) f.set_attribute("/", "pointfair_format", std::string_view(tiles::layout::format_name));
  f.set_attribute("/", "format_version", (flags & 2) ? std::int64_t{2} : tiles::layout::format_version);
  f.create_group(tiles::layout::points);
  f.create_group(tiles::layout::tiles);
  const h5::DatasetOptions chunked{.chunk_rows = 1 + in.below(16)};
  const std::uint64_t width = (flags & 4) ? 2 : 3;
  {
    h5::Dataset d = f.create_dataset(tiles::layout::positions, h5::Type::Float64, n, width, chunked);
    std::vector<double> v(n * width);
    for (double& x : v) x = in.real();
    if (n > 0) d.write_rows(0, n, v.data());
  }
  if (!(flags & 8)) {
    const std::uint64_t rows = n + in.below(3) - (n > 0 ? in.below(2) : 0);
    h5::Dataset d = f.create_dataset(tiles::layout::original_index, h5::Type::UInt64, rows, 0, chunked);
    std::vector<std::uint64_t> v(rows);
    const bool permutation = in.u8() < 128;
    for (std::uint64_t i = 0; i < rows; ++i) v[i] = permutation ? (i * 7 + 3) % std::max<std::uint64_t>(rows, 1) : in.below(n + 2);
    if (permutation && rows > 0 && rows % 7 == 0) for (std::uint64_t i = 0; i < rows; ++i) v[i] = rows - 1 - i;
    if (rows > 0) d.write_rows(0, rows, v.data());
  }
  {
    std::vector<std::uint64_t> offsets(tiles + 1);
    for (std::uint64_t t = 0; t <= tiles; ++t) offsets[t] = in.u8() < 192 ? (n * t) / std::max<std::uint64_t>(tiles, 1) : in.below(n + 3);
    if (in.u8() < 192 && !offsets.empty()) {
      offsets.front() = 0;
      offsets.back() = n;
    }
    h5::Dataset d = f.create_dataset(tiles::layout::tile_offsets, h5::Type::UInt64, offsets.size(), 0);
    d.write_rows(0, offsets.size(), offsets.data());
    const std::uint64_t bound_rows = tiles + in.below(2);
    h5::Dataset b = f.create_dataset(tiles::layout::tile_bounds, h5::Type::Float64, bound_rows, 6);
    std::vector<double> box(bound_rows * 6);
    for (double& x : box) x = in.real();
    if (bound_rows > 0) b.write_rows(0, bound_rows, box.data());
  }
  if (flags & 16) {
    f.create_group(tiles::layout::attributes);
    const std::uint64_t rows = n + in.below(2);
    h5::Dataset d = f.create_dataset(std::string(tiles::layout::attributes) + "/intensity", h5::Type::UInt16, rows, 0);
    std::vector<std::uint16_t> v(rows);
    for (auto& x : v) x = in.u8();
    if (rows > 0) d.write_rows(0, rows, v.data());
  }
  if (flags & 32) {
    f.create_group(tiles::layout::run);
    const std::uint64_t state_rows = 1 + in.below(4);
    h5::Dataset s = f.create_dataset(tiles::layout::run_state, h5::Type::Int64, state_rows, 0);
    std::vector<std::int64_t> state(state_rows, 1);
    s.write_rows(0, state_rows, state.data());
    f.set_attribute(tiles::layout::run, "result_positions",
                    std::string_view(in.u8() < 128 ? "/points/positions" : "/run/positions_1"));
  }
  f.flush();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const fs::path input = scratch("in.h5"), output = scratch("out.h5");
  Bytes in(data, size);
  try {
    build(input, in);
  } catch (const io::IoError&) {
    return 0;  // not a file our writer can make
  }
  for (const bool original_order : {true, false}) {
    try {
      const io::PointTable t = tiles::read_container(input, {.original_order = original_order});
      for (const io::Attribute& a : t.attributes)
        if (a.values.size() != t.size()) std::abort();
    } catch (const io::IoError&) {
    }
  }
  try {
    tiles::read_run_attributes(input);
  } catch (const io::IoError&) {
  }
  try {
    SmoothParams params;
    params.finish.reset();  // the flow alone
    params.steps = 1;
    params.neighbors.k = 4;
    tiles::smooth_out_of_core(input, output, params, {.memory_budget = std::uint64_t{64} << 20});
  } catch (const io::IoError&) {
  } catch (const ParamError&) {
  }
  std::error_code ec;
  fs::remove(output, ec);
  fs::remove(tiles::partial_name(output), ec);
  return 0;
}
