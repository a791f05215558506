// LAS reader: public header, VLRs, point records (in blocks), EVLRs, each checked against
// the file size before it is read or allocated. LAZ files are read the same way, their
// records decompressed a chunk at a time (laz/point_reader.hpp).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <functional>
#include <optional>
#include <limits>
#include <string>
#include <vector>

#include "file_reader.hpp"
#include "io_error.hpp"
#include "las_format.hpp"
#include "laz/laszip_vlr.hpp"
#include "laz/point_reader.hpp"
#include "pointfair/io/las.hpp"
#include "scalar_codec.hpp"
#include "table_checks.hpp"

namespace pointfair::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

constexpr std::size_t kBlockBytes = std::size_t{4} << 20;
// Points of a LAZ file decoded into a table before it grows for the next ones.
constexpr std::size_t kLazPiecePoints = std::size_t{1} << 18;
// Doubles hold every integer up to 2^53 exactly; 64-bit fields beyond it are rounded.
constexpr double kExactIntegerLimit = 9007199254740992.0;

std::string read_exact(FileReader& reader, std::uint64_t size, std::string_view what) {
  if (size > reader.remaining()) {
    fail(reader.path(), "truncated file: " + std::string(what) + " needs " + std::to_string(size) +
                            " bytes, " + std::to_string(reader.remaining()) + " remain");
  }
  std::string bytes(static_cast<std::size_t>(size), '\0');
  reader.read(bytes.data(), bytes.size());
  return bytes;
}

std::uint64_t position_of(const FileReader& reader) { return reader.size() - reader.remaining(); }

void skip_to(FileReader& reader, std::uint64_t target, std::string_view what) {
  const std::uint64_t here = position_of(reader);
  if (target < here) fail(reader.path(), std::string(what) + " starts at byte " + std::to_string(target) +
                                             ", inside the data before it (byte " + std::to_string(here) + ")");
  if (target > reader.size()) fail(reader.path(), std::string(what) + " starts at byte " + std::to_string(target) +
                                                      ", beyond the end of the file (" +
                                                      std::to_string(reader.size()) + " bytes)");
  reader.skip(target - here);
}

LasHeader read_header(FileReader& reader) {
  const fs::path& file = reader.path();
  std::string bytes = read_exact(reader, std::min<std::uint64_t>(reader.size(), las_header_size(0)), "the header");
  if (bytes.size() >= 26 && bytes.compare(0, 4, "LASF") == 0) {
    const auto minor = static_cast<unsigned char>(bytes[25]);
    const std::size_t needed = las_header_size(minor);
    if (minor <= 4 && needed > bytes.size()) {
      bytes += read_exact(reader, std::min<std::uint64_t>(reader.remaining(), needed - bytes.size()), "the header");
    }
  }
  LasHeader h = parse_las_header(file, bytes);
  if (h.header_size > reader.size()) {
    fail(file, "truncated header: header size " + std::to_string(h.header_size) + " exceeds the file size (" +
                   std::to_string(reader.size()) + " bytes)");
  }
  skip_to(reader, h.header_size, "the end of the header");

  if (h.point_format > kMaxPointFormat) {
    fail(file, "unknown point data format " + std::to_string(h.point_format) + " (expected 0 to 10)");
  }
  if (h.record_length < point_record_size(h.point_format)) {
    fail(file, "point record length " + std::to_string(h.record_length) + " is smaller than the " +
                   std::to_string(point_record_size(h.point_format)) + " bytes of point format " +
                   std::to_string(h.point_format));
  }
  if (h.point_data_offset < h.header_size) {
    fail(file, "offset to point data " + std::to_string(h.point_data_offset) +
                   " lies inside the header (" + std::to_string(h.header_size) + " bytes)");
  }
  if (h.point_data_offset > reader.size()) {
    fail(file, "offset to point data " + std::to_string(h.point_data_offset) +
                   " lies beyond the end of the file (" + std::to_string(reader.size()) + " bytes)");
  }
  const char* axes = "xyz";
  for (std::size_t a = 0; a < 3; ++a) {
    if (!std::isfinite(h.scale[a]) || h.scale[a] == 0 || !std::isfinite(h.offset[a])) {
      fail(file, std::string(1, axes[a]) + " scale factor " + std::to_string(h.scale[a]) + " or offset " +
                     std::to_string(h.offset[a]) + " is not usable (scales must be finite and non-zero)");
    }
  }
  return h;
}

// The LASzip VLR, which describes the compression of a LAZ file, goes to `laszip` (it is
// not metadata of the points: a LAS copy must not carry it).
void read_vlrs(FileReader& reader, const LasHeader& h, LasMetadata& metadata, std::optional<std::string>& laszip) {
  const fs::path& file = reader.path();
  const std::uint64_t space = h.point_data_offset - h.header_size;
  if (std::uint64_t{h.vlr_count} * kVlrHeaderSize > space) {
    fail(file, std::to_string(h.vlr_count) + " VLRs do not fit in the " + std::to_string(space) +
                   " bytes between the header and the point data");
  }
  bool have_extra_bytes = false;
  for (std::uint32_t v = 0; v < h.vlr_count; ++v) {
    const std::string name = "VLR " + std::to_string(v);
    const std::string head = read_exact(reader, kVlrHeaderSize, name);
    const auto length = static_cast<std::uint16_t>(load_le(LasStorage::U16, head.data() + 20));
    if (position_of(reader) + length > h.point_data_offset) {
      fail(file, name + " (" + std::to_string(length) + " bytes) runs past the start of the point data");
    }
    LasRecord record;
    record.user_id = fixed_text(std::string_view(head).substr(2, 16));
    record.record_id = static_cast<std::uint16_t>(load_le(LasStorage::U16, head.data() + 18));
    record.description = fixed_text(std::string_view(head).substr(22, 32));
    record.data = read_exact(reader, length, name);
    if (record.user_id == laz::kLaszipUserId && record.record_id == laz::kLaszipRecordId) {
      if (laszip) fail(file, "more than one LASzip VLR");
      laszip = std::move(record.data);
    } else if (record.user_id == kLasSpecUserId && record.record_id == kExtraBytesRecordId) {
      if (have_extra_bytes) fail(file, "more than one Extra Bytes VLR");
      have_extra_bytes = true;
      metadata.extra_bytes_descriptors = std::move(record.data);
    } else {
      metadata.records.push_back(std::move(record));
    }
  }
}

void read_evlrs(FileReader& reader, const LasHeader& h, LasMetadata& metadata) {
  const fs::path& file = reader.path();
  if (h.version_minor < 4 || h.evlr_count == 0) return;
  skip_to(reader, h.evlr_start, "the first EVLR");
  if (std::uint64_t{h.evlr_count} * kEvlrHeaderSize > reader.remaining()) {
    fail(file, std::to_string(h.evlr_count) + " EVLRs do not fit in the " + std::to_string(reader.remaining()) +
                   " bytes after their start");
  }
  for (std::uint32_t v = 0; v < h.evlr_count; ++v) {
    const std::string name = "EVLR " + std::to_string(v);
    const std::string head = read_exact(reader, kEvlrHeaderSize, name);
    const auto length = load_scalar<std::uint64_t, needs_swap(false)>(head.data() + 20);
    LasRecord record;
    record.user_id = fixed_text(std::string_view(head).substr(2, 16));
    record.record_id = static_cast<std::uint16_t>(load_le(LasStorage::U16, head.data() + 18));
    record.description = fixed_text(std::string_view(head).substr(28, 32));
    record.data = read_exact(reader, length, name);
    record.extended = true;
    metadata.records.push_back(std::move(record));
  }
}

// Where a value of a record goes: a standard field or an extra column.
struct Column {
  LasStorage storage;
  std::size_t offset;  // in the record
  unsigned shift = 0;
  unsigned bits = 0;
  std::size_t attribute = 0;
  bool wide = false;  // a 64-bit integer, exact only up to 2^53
};

// `compressed`: LAZ records have no fixed size (the LAZ reader checks its chunks instead).
void check_point_count(FileReader& reader, const LasHeader& h, bool compressed) {
  const fs::path& file = reader.path();
  const std::size_t record = h.record_length;
  const std::uint64_t available = reader.remaining() / record;
  if (!compressed && h.point_count > available) {
    fail(file, "header declares " + std::to_string(h.point_count) + " points but the file holds only " +
                   std::to_string(available) + " records of " + std::to_string(record) + " bytes");
  }
  if (h.point_count > std::numeric_limits<Index>::max()) {
    fail(file, std::to_string(h.point_count) + " points exceed the limit of " +
                   std::to_string(std::numeric_limits<Index>::max()) + " points per file");
  }
}

// The next `records` point records (as stored in a LAS file) into `out`.
using ReadRecords = std::function<void(char* out, std::size_t records)>;

// Appends records [first, first + count) to `table`, a block at a time. `rounded` (one flag
// per column) keeps the 2^53 warning to one per column and file.
void read_points_into(const fs::path& file, const ReadRecords& read_records, const LasHeader& h, const std::vector<Column>& columns,
                      const ReadOptions& options, std::size_t first, std::size_t count,
                      std::vector<bool>& rounded, std::vector<char>& block, PointTable& table) {
  const std::size_t record = h.record_length;
  const std::size_t start = table.positions.size();
  table.positions.resize(start + count);
  for (Attribute& attribute : table.attributes) attribute.values.resize(start + count);

  const std::size_t block_records = std::max<std::size_t>(1, kBlockBytes / record);
  block.resize(std::min(count, block_records) * record);
  for (std::size_t done = 0; done < count; done += block_records) {
    const std::size_t records = std::min(block_records, count - done);
    const std::size_t at = start + done;
    read_records(block.data(), records);
    for (std::size_t r = 0; r < records; ++r) {
      const char* bytes = block.data() + r * record;
      Vec3& p = table.positions[at + r];
      for (int a = 0; a < 3; ++a) {
        const double stored = load_le(LasStorage::I32, bytes + 4 * a);
        p[a] = h.offset[a] + h.scale[a] * stored;
      }
      check_finite_point(file, p, first + done + r, "point");
    }
    for (std::size_t c = 0; c < columns.size(); ++c) {
      const Column& column = columns[c];
      double* out = table.attributes[column.attribute].values.data() + at;
      const char* bytes = block.data() + column.offset;
      if (column.bits > 0) {
        const unsigned mask = (1u << column.bits) - 1;
        for (std::size_t r = 0; r < records; ++r) {
          const auto byte = static_cast<unsigned char>(bytes[r * record]);
          out[r] = static_cast<double>((byte >> column.shift) & mask);
        }
      } else {
        for (std::size_t r = 0; r < records; ++r) out[r] = load_le(column.storage, bytes + r * record);
      }
      if (column.wide && !rounded[c]) {
        for (std::size_t r = 0; r < records; ++r) {
          if (std::abs(out[r]) > kExactIntegerLimit) rounded[c] = true;
        }
        if (rounded[c]) {
          warn(options, file, "attribute '" + table.attributes[column.attribute].name +
                                  "' has 64-bit values beyond 2^53 that are rounded");
        }
      }
    }
    check_attribute_values(file, table, at, first + done, "point");
  }
}

}  // namespace

namespace {

// The header and VLRs are read when the reader opens, the point records in chunks, the EVLRs
// after the last record (schema().las holds them from then on).
class LasChunkReader final : public PointChunkReader {
 public:
  LasChunkReader(const fs::path& file, const ReadOptions& options)
      : PointChunkReader(file), options_(options), reader_(file) {
    h_ = read_header(reader_);
    LasMetadata metadata;
    metadata.version_minor = h_.version_minor;
    metadata.point_format = h_.point_format;
    metadata.file_source_id = h_.file_source_id;
    metadata.global_encoding = h_.global_encoding;
    metadata.project_guid = h_.project_guid;
    metadata.system_identifier = h_.system_identifier;
    std::optional<std::string> laszip;
    read_vlrs(reader_, h_, metadata, laszip);
    skip_to(reader_, h_.point_data_offset, "the point data");
    const bool compressed = (h_.format_byte & 0xc0) != 0;
    if (compressed != laszip.has_value()) {
      fail(file, compressed ? "the point format has the compression bit (LAZ) but there is no LASzip VLR"
                            : "a LASzip VLR (LAZ) is present but the point format lacks the compression bit");
    }
    if (compressed) {
      const laz::LaszipInfo info = laz::parse_laszip_vlr(file, *laszip);
      laz::require_decodable(file, info, h_.point_format, h_.record_length);
      const bool evlrs = h_.version_minor >= 4 && h_.evlr_count > 0 && h_.evlr_start > h_.point_data_offset;
      laz_.emplace(reader_, info, h_.point_data_offset, evlrs ? std::min(h_.evlr_start, reader_.size()) : reader_.size(),
                   h_.point_count, h_.record_length);
    }

    schema_.position_type = ScalarType::Float64;
    schema_.quantization = PositionQuantization{Vec3(h_.scale[0], h_.scale[1], h_.scale[2]),
                                                Vec3(h_.offset[0], h_.offset[1], h_.offset[2])};
    for (const LasField& field : las_fields(h_.point_format)) {
      columns_.push_back({field.storage, field.offset, field.shift, field.bits, schema_.attributes.size(),
                          field.storage == LasStorage::U64 || field.storage == LasStorage::I64});
      schema_.attributes.push_back(Attribute{std::string(field.name), field.type, {}});
    }
    const std::size_t base = point_record_size(h_.point_format);
    schema_.attributes.reserve(columns_.size() + (h_.record_length - base));
    columns_.reserve(schema_.attributes.capacity());
    for (ExtraColumn& extra :
         extra_columns(file, h_.point_format, metadata.extra_bytes_descriptors, h_.record_length - base)) {
      columns_.push_back({extra.storage, base + extra.offset, 0, 0, schema_.attributes.size(),
                          extra.storage == LasStorage::U64 || extra.storage == LasStorage::I64});
      schema_.attributes.push_back(Attribute{std::move(extra.name), extra.type, {}});
    }
    schema_.las = std::move(metadata);
    rounded_.assign(columns_.size(), false);
    check_point_count(reader_, h_, compressed);
  }

  std::optional<std::uint64_t> count() const override { return h_.point_count; }

 protected:
  bool seek_over(std::uint64_t points) override {
    // Records of h_.record_length bytes; the last one is read, not skipped, so that the
    // EVLRs after it are read as usual.
    if (points_read_ + points >= h_.point_count) return false;
    if (laz_) return laz_->skip(points);
    const std::uint64_t bytes = points * h_.record_length;
    if (reader_.skip(bytes) != bytes) fail(path_, "truncated point data");
    return true;
  }

  std::size_t append(PointTable& chunk, std::size_t max_points) override {
    const std::uint64_t left = h_.point_count - points_read_;
    const auto count = static_cast<std::size_t>(std::min<std::uint64_t>(left, max_points));
    // A LAZ header's point count is not bounded by the file size (the LAS check): its points
    // are allocated as they decode, so a false count fails at the chunk that lacks them.
    const std::size_t piece = laz_ ? kLazPiecePoints : std::max<std::size_t>(count, 1);
    for (std::size_t done = 0; done < count; done += piece) {
      read_points_into(path_, read_records_, h_, columns_, options_, static_cast<std::size_t>(points_read_) + done,
                       std::min(piece, count - done), rounded_, block_, chunk);
    }
    if (points_read_ + count == h_.point_count && !finished_) {
      finished_ = true;
      block_ = std::vector<char>();
      if ((h_.global_encoding & 2) != 0) {
        warn(options_, path_, "waveform data packets stored inside the file are not kept");
      }
      read_evlrs(reader_, h_, *schema_.las);
    }
    chunk.quantization = schema_.quantization;
    chunk.las = schema_.las;
    return count;
  }

 private:
  ReadOptions options_;
  FileReader reader_;
  std::optional<laz::LazRecordReader> laz_;
  // From laz_ when the file is LAZ, else straight from the file.
  ReadRecords read_records_ = [this](char* out, std::size_t records) {
    if (laz_) {
      laz_->read(out, records);
    } else if (reader_.read(out, records * h_.record_length) != records * h_.record_length) {
      fail(path_, "truncated point data");
    }
  };
  LasHeader h_;
  std::vector<Column> columns_;
  std::vector<bool> rounded_;
  std::vector<char> block_;
  bool finished_ = false;
};

}  // namespace

std::unique_ptr<PointChunkReader> open_las_reader(const fs::path& file, const ReadOptions& options) {
  return std::make_unique<LasChunkReader>(file, options);
}

PointTable read_las(const fs::path& file, const ReadOptions& options) {
  LasChunkReader reader(file, options);
  PointTable table = reader.schema();
  reader.read(table, static_cast<std::size_t>(std::max<std::uint64_t>(1, *reader.count())));
  table.las = reader.schema().las;  // with the EVLRs read after the points
  return table;
}

}  // namespace pointfair::io
