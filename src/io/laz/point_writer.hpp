#pragma once
// Compresses point records (the bytes of an uncompressed LAS file's records) into LAZ
// chunks as they arrive, one chunk in memory; finish() writes the chunk table.
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "laz/arithmetic_coder.hpp"
#include "laz/chunk_table.hpp"
#include "laz/item_codec.hpp"
#include "laz/laszip_vlr.hpp"
#include "laz/layered14.hpp"
#include "pointfair/io/atomic_file.hpp"

namespace pointfair::io::laz {

class LazRecordWriter {
 public:
  /// Records go to `sink`, whose next byte is at file offset `point_data_start`; writes
  /// the placeholder of the chunk table offset. `info` from laszip_info_for.
  LazRecordWriter(FileSink& sink, const LaszipInfo& info, std::uint64_t point_data_start, std::size_t record_length);

  /// Appends `count` records of record_length bytes.
  void write(const char* records, std::size_t count);
  /// Writes the last chunk and the chunk table, and the table's offset at the start of the
  /// point data. Returns the file offset after the table (where EVLRs may follow).
  std::uint64_t finish();

 private:
  void finish_chunk();

  FileSink& sink_;
  LaszipInfo info_;
  std::size_t record_length_;
  std::uint64_t point_data_start_;
  std::uint64_t position_;  // file offset of the next byte written to sink_
  std::vector<std::unique_ptr<ItemCodec>> items_;
  std::vector<std::size_t> item_offsets_;
  std::vector<std::uint8_t> chunk_;
  std::optional<ArithmeticEncoder> encoder_;
  std::unique_ptr<Layered14Codec> layered_;  // point formats 6-8
  std::uint64_t in_chunk_ = 0;
  std::vector<ChunkEntry> table_;
};

}  // namespace pointfair::io::laz
