#pragma once
// Decompresses the point records of a LAZ file a chunk at a time, into the bytes the same
// records have in an uncompressed LAS file (so the LAS reader decodes their fields): point
// formats 0-3 item by item (item_codec.hpp), 6-8 layer by layer (layered14.hpp).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

#include "file_reader.hpp"
#include "laz/arithmetic_coder.hpp"
#include "laz/chunk_bytes.hpp"
#include "laz/chunk_table.hpp"
#include "laz/item_codec.hpp"
#include "laz/laszip_vlr.hpp"
#include "laz/layered14.hpp"

namespace pointfair::io::laz {

class LazRecordReader {
 public:
  /// `reader` is at `point_data_start`, the first byte of the point data (the chunk table
  /// offset); `points` records of `record_length` bytes follow, compressed as `info` says
  /// (checked with require_decodable). `data_end`: no point data lies at or beyond it (the
  /// start of the EVLRs, else the file size). Throws IoError "<file>: ..." for an unusable
  /// chunk table.
  LazRecordReader(detail::FileReader& reader, const LaszipInfo& info, std::uint64_t point_data_start,
                  std::uint64_t data_end, std::uint64_t points, std::size_t record_length);

  /// The next `count` records into `out` (count * record_length bytes). Throws IoError
  /// "<file>: chunk <k> of <n> ..." for a truncated or corrupt chunk.
  void read(char* out, std::size_t count);
  /// Passes over the next `count` records: whole chunks by the chunk table, without
  /// decoding them; the others are decoded. False (nothing done) when the table was lost.
  bool skip(std::uint64_t count);

 private:
  void start_chunk();
  void finish_chunk();
  void start_layered_chunk(std::uint8_t* record);
  [[noreturn]] void fail_chunk(const std::string& problem) const;

  std::filesystem::path file_;
  LaszipInfo info_;
  std::size_t record_length_;
  std::uint64_t points_;
  ChunkBytes bytes_;
  std::optional<std::vector<ChunkEntry>> table_;  // nullopt: lost, chunks are read in sequence
  std::uint64_t chunk_count_ = 0;
  std::uint64_t chunk_ = 0;             // the current chunk
  std::uint64_t chunk_start_ = 0;       // its file offset
  std::uint64_t left_in_chunk_ = 0;     // points of it not yet decoded
  std::uint64_t decoded_ = 0;           // points decoded so far
  // Point formats 0-3: one codec per item, one coded stream per chunk.
  std::vector<std::unique_ptr<ItemCodec>> items_;
  std::vector<std::size_t> item_offsets_;
  std::optional<ArithmeticDecoder> decoder_;
  // Point formats 6-8: the layered codec, started when a chunk is (chunk_started_).
  std::unique_ptr<Layered14Codec> layered_;
  bool chunk_started_ = false;
};

}  // namespace pointfair::io::laz
