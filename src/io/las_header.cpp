// The LAS public header: parsing (with the checks that do not need the rest of the file)
// and serialisation, for versions 1.0 to 1.4.
#include <bit>
#include <cstring>
#include <string>

#include "io_error.hpp"
#include "las_format.hpp"

namespace pointfair::io::detail {

namespace {

class Cursor {
 public:
  explicit Cursor(std::string_view bytes) : bytes_(bytes) {}
  template <typename T>
  T get(std::size_t at) const {
    T value;
    std::memcpy(&value, bytes_.data() + at, sizeof(T));
    return value;  // little endian machines only: checked by the static_assert below
  }
  std::string_view text(std::size_t at, std::size_t size) const { return bytes_.substr(at, size); }

 private:
  std::string_view bytes_;
};

class Writer {
 public:
  explicit Writer(std::size_t size) : bytes_(size, '\0') {}
  template <typename T>
  void put(std::size_t at, T value) {
    std::memcpy(bytes_.data() + at, &value, sizeof(T));
  }
  void text(std::size_t at, std::string_view value) { bytes_.replace(at, value.size(), value); }
  std::string take() { return std::move(bytes_); }

 private:
  std::string bytes_;
};

static_assert(std::endian::native == std::endian::little,
              "the LAS header code assumes a little-endian machine");

}  // namespace

LasHeader parse_las_header(const std::filesystem::path& file, std::string_view bytes) {
  if (bytes.size() < 4 || bytes.substr(0, 4) != "LASF") {
    fail(file, "not a LAS file (the file does not start with the signature LASF)");
  }
  if (bytes.size() < las_header_size(0)) {
    fail(file, "truncated header: " + std::to_string(bytes.size()) + " bytes, a LAS header has at least " +
                   std::to_string(las_header_size(0)));
  }
  const Cursor c(bytes);
  LasHeader h;
  h.file_source_id = c.get<std::uint16_t>(4);
  h.global_encoding = c.get<std::uint16_t>(6);
  h.project_guid = std::string(c.text(8, 16));
  h.version_major = c.get<std::uint8_t>(24);
  h.version_minor = c.get<std::uint8_t>(25);
  if (h.version_major != 1 || h.version_minor > 4) {
    fail(file, "unsupported LAS version " + std::to_string(h.version_major) + "." +
                   std::to_string(h.version_minor) + " (expected 1.0 to 1.4)");
  }
  h.system_identifier = fixed_text(c.text(26, 32));
  h.generating_software = fixed_text(c.text(58, 32));
  h.creation_day = c.get<std::uint16_t>(90);
  h.creation_year = c.get<std::uint16_t>(92);
  h.header_size = c.get<std::uint16_t>(94);
  const std::size_t needed = las_header_size(h.version_minor);
  if (h.header_size < needed) {
    fail(file, "header size " + std::to_string(h.header_size) + " is smaller than the " +
                   std::to_string(needed) + " bytes of a LAS 1." + std::to_string(h.version_minor) +
                   " header");
  }
  if (bytes.size() < needed) {
    fail(file, "truncated header: " + std::to_string(bytes.size()) + " bytes, LAS 1." +
                   std::to_string(h.version_minor) + " needs " + std::to_string(needed));
  }
  h.point_data_offset = c.get<std::uint32_t>(96);
  h.vlr_count = c.get<std::uint32_t>(100);
  h.format_byte = c.get<std::uint8_t>(104);
  h.point_format = h.format_byte & 0x3f;
  h.record_length = c.get<std::uint16_t>(105);
  h.point_count = c.get<std::uint32_t>(107);
  for (int r = 0; r < 5; ++r) h.points_by_return[r] = c.get<std::uint32_t>(111 + 4 * static_cast<std::size_t>(r));
  for (std::size_t a = 0; a < 3; ++a) {
    h.scale[a] = c.get<double>(131 + 8 * a);
    h.offset[a] = c.get<double>(155 + 8 * a);
    h.max[a] = c.get<double>(179 + 16 * a);
    h.min[a] = c.get<double>(187 + 16 * a);
  }
  if (h.version_minor >= 3) h.waveform_start = c.get<std::uint64_t>(227);
  if (h.version_minor >= 4) {
    h.evlr_start = c.get<std::uint64_t>(235);
    h.evlr_count = c.get<std::uint32_t>(243);
    const auto count = c.get<std::uint64_t>(247);
    // The 64-bit count is authoritative in 1.4; some writers leave it 0 and fill the legacy one.
    if (count != 0 || h.point_count == 0) h.point_count = count;
    for (std::size_t r = 0; r < 15; ++r) h.points_by_return[r] = c.get<std::uint64_t>(255 + 8 * r);
  }
  return h;
}

std::string serialize_las_header(const LasHeader& h) {
  Writer w(h.header_size);
  w.text(0, "LASF");
  w.put<std::uint16_t>(4, h.file_source_id);
  w.put<std::uint16_t>(6, h.global_encoding);
  w.text(8, padded(h.project_guid, 16));
  w.put<std::uint8_t>(24, static_cast<std::uint8_t>(h.version_major));
  w.put<std::uint8_t>(25, static_cast<std::uint8_t>(h.version_minor));
  w.text(26, padded(h.system_identifier, 32));
  w.text(58, padded(h.generating_software, 32));
  w.put<std::uint16_t>(90, h.creation_day);
  w.put<std::uint16_t>(92, h.creation_year);
  w.put<std::uint16_t>(94, h.header_size);
  w.put<std::uint32_t>(96, h.point_data_offset);
  w.put<std::uint32_t>(100, h.vlr_count);
  w.put<std::uint8_t>(104, static_cast<std::uint8_t>(h.point_format | (h.format_byte & 0xc0)));
  w.put<std::uint16_t>(105, h.record_length);
  // Legacy counts: 0 when they do not fit or the format is a 1.4 one (as the spec asks).
  const bool legacy = h.point_format < 6 && h.point_count <= 0xffffffffu;
  w.put<std::uint32_t>(107, legacy ? static_cast<std::uint32_t>(h.point_count) : 0);
  for (std::size_t r = 0; r < 5; ++r) {
    const std::uint64_t n = h.points_by_return[r];
    w.put<std::uint32_t>(111 + 4 * r, legacy && n <= 0xffffffffu ? static_cast<std::uint32_t>(n) : 0);
  }
  for (std::size_t a = 0; a < 3; ++a) {
    w.put<double>(131 + 8 * a, h.scale[a]);
    w.put<double>(155 + 8 * a, h.offset[a]);
    w.put<double>(179 + 16 * a, h.max[a]);
    w.put<double>(187 + 16 * a, h.min[a]);
  }
  if (h.version_minor >= 3) w.put<std::uint64_t>(227, h.waveform_start);
  if (h.version_minor >= 4) {
    w.put<std::uint64_t>(235, h.evlr_start);
    w.put<std::uint32_t>(243, h.evlr_count);
    w.put<std::uint64_t>(247, h.point_count);
    for (std::size_t r = 0; r < 15; ++r) w.put<std::uint64_t>(255 + 8 * r, h.points_by_return[r]);
  }
  return w.take();
}

}  // namespace pointfair::io::detail
