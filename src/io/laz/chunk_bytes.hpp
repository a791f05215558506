#pragma once
// The compressed bytes of a LAZ file's point data as a decoder consumes them: read from
// the file a block at a time, never past a limit (the end of the current chunk, or of the
// file when the chunk table is lost), so one chunk at most is held in memory.
#include <cstdint>
#include <vector>

#include "file_reader.hpp"

namespace pointfair::io::laz {

/// Thrown when a decoder needs a byte beyond the limit: the chunk is corrupt or truncated.
/// Caught by the chunk reader, which names the file and the chunk.
struct ChunkOverrun {};

class ChunkBytes {
 public:
  /// Bytes from the current position of `reader` (which this object then owns the reading of).
  ChunkBytes(detail::FileReader& reader, std::uint64_t position)
      : reader_(&reader), buffer_end_position_(position), limit_(position) {}
  /// The bytes of `data` (one layer of a chunk), positions counted from 0.
  explicit ChunkBytes(std::vector<std::uint8_t> data)
      : buffer_(std::move(data)), end_(buffer_.size()), stop_(end_), buffer_end_position_(end_), limit_(end_) {}

  /// The file position of the next byte.
  std::uint64_t position() const { return buffer_end_position_ - (end_ - next_); }
  /// No byte at or beyond file position `limit` is read.
  void set_limit(std::uint64_t limit);
  std::uint64_t limit() const { return limit_; }

  std::uint8_t get() {
    if (next_ == stop_) refill();
    return buffer_[next_++];
  }
  void get(std::uint8_t* out, std::size_t count) {
    for (std::size_t i = 0; i < count; ++i) out[i] = get();
  }
  /// Passes over the bytes up to file position `target` (position() <= target <= limit()).
  void skip_to(std::uint64_t target);

 private:
  void refill();

  detail::FileReader* reader_ = nullptr;  // nullptr: the bytes are all in buffer_
  std::vector<std::uint8_t> buffer_;
  std::size_t next_ = 0, end_ = 0;
  std::size_t stop_ = 0;  // min(end_, the index of the limit): get() reads no further
  std::uint64_t buffer_end_position_;  // file position of buffer_[end_]
  std::uint64_t limit_;
};

}  // namespace pointfair::io::laz
