#include "laz/point_reader.hpp"

#include <cassert>
#include <cstring>
#include <string>

#include "io_error.hpp"

namespace pointfair::io::laz {

LazRecordReader::LazRecordReader(detail::FileReader& reader, const LaszipInfo& info, std::uint64_t point_data_start,
                                 std::uint64_t data_end, std::uint64_t points, std::size_t record_length)
    : file_(reader.path()), info_(info), record_length_(record_length), points_(points), bytes_(reader, point_data_start) {
  if (info_.compressor == kLayeredChunked) {
    const std::size_t base = info_.items.size() > 1 && info_.items[1].type != ItemType::Byte14 ? 30 + info_.items[1].size : 30;
    const int format = base == 30 ? 6 : base == 36 ? 7 : 8;
    layered_ = std::make_unique<Layered14Codec>(format, record_length_ - base);
  } else {
    std::size_t offset = 0;
    for (const LazItem& item : info_.items) {
      items_.push_back(make_item_codec_v2(item));
      item_offsets_.push_back(offset);
      offset += item.size;
    }
    assert(offset == record_length_);
  }
  if (points_ == 0) return;

  const bool variable = info_.chunk_size == kVariableChunkSize;
  bytes_.set_limit(data_end);
  std::uint8_t head[8];
  try {
    bytes_.get(head, 8);
  } catch (const ChunkOverrun&) {
    detail::fail(file_, "truncated file: the LAZ point data ends before its chunk table offset");
  }
  std::int64_t table_offset;
  std::memcpy(&table_offset, head, 8);
  if (table_offset == -1) {
    // Written by a writer that could not seek back: the offset is in the file's last 8 bytes.
    detail::FileReader tail(file_);
    if (tail.size() >= 8) {
      tail.skip(tail.size() - 8);
      tail.read(reinterpret_cast<char*>(&table_offset), 8);
    }
  }
  const std::uint64_t first_chunk = point_data_start + 8;
  if (table_offset > 0 && static_cast<std::uint64_t>(table_offset) >= first_chunk) {
    table_ = read_chunk_table(file_, static_cast<std::uint64_t>(table_offset), variable);
  }
  // Fixed chunk sizes: every chunk but the last one is full.
  if (table_ && !variable && table_->size() != (points_ + info_.chunk_size - 1) / info_.chunk_size) table_.reset();
  if (table_) {
    std::uint64_t total_points = 0, total_bytes = 0;
    for (ChunkEntry& chunk : *table_) {
      if (!variable) chunk.points = std::min<std::uint64_t>(info_.chunk_size, points_ - std::min(points_, total_points));
      total_points += chunk.points;
      total_bytes += chunk.bytes;
    }
    // A table that disagrees with the header is not used: the chunks are read in sequence.
    if (total_points != points_ || first_chunk + total_bytes > static_cast<std::uint64_t>(table_offset)) table_.reset();
  }
  if (table_) {
    chunk_count_ = table_->size();
  } else if (variable) {
    detail::fail(file_, "the LAZ chunk table (at byte " + std::to_string(table_offset) +
                            ") is missing, truncated or corrupt, and the chunks vary in size, so the points cannot be found");
  } else {
    chunk_count_ = (points_ + info_.chunk_size - 1) / info_.chunk_size;
  }
}

void LazRecordReader::fail_chunk(const std::string& problem) const {
  detail::fail(file_, "LAZ chunk " + std::to_string(chunk_) + " of " + std::to_string(chunk_count_) + " (starting at byte " +
                          std::to_string(chunk_start_) + ") " + problem);
}

void LazRecordReader::start_chunk() {
  chunk_start_ = bytes_.position();
  if (table_) {
    const ChunkEntry& entry = (*table_)[chunk_];
    left_in_chunk_ = entry.points;
    bytes_.set_limit(chunk_start_ + entry.bytes);
  } else {
    left_in_chunk_ = std::min<std::uint64_t>(info_.chunk_size, points_ - decoded_);
  }
}

void LazRecordReader::finish_chunk() {
  if (table_) {
    const std::uint64_t end = chunk_start_ + (*table_)[chunk_].bytes;
    if (bytes_.position() != end) {
      fail_chunk("is corrupt: its points end at byte " + std::to_string(bytes_.position()) +
                 " but the chunk table says the chunk ends at byte " + std::to_string(end));
    }
  }
  ++chunk_;
  decoder_.reset();
  chunk_started_ = false;
}

void LazRecordReader::start_layered_chunk(std::uint8_t* record) {
  bytes_.get(record, record_length_);
  std::uint8_t word[4];
  bytes_.get(word, 4);  // the chunk's point count (the table's, or the header's, is used)
  std::vector<std::uint32_t> sizes(layered_->layer_count());
  for (std::uint32_t& size : sizes) {
    bytes_.get(word, 4);
    std::memcpy(&size, word, 4);
  }
  std::vector<std::vector<std::uint8_t>> layers(sizes.size());
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    // Each byte is checked against the chunk's end before the layer grows past it.
    for (std::uint32_t b = 0; b < sizes[i]; ++b) layers[i].push_back(bytes_.get());
  }
  layered_->start_decoding(record, std::move(layers));
}

bool LazRecordReader::skip(std::uint64_t count) {
  if (!table_) return false;
  std::vector<char> scratch(record_length_);
  while (count > 0) {
    const bool at_chunk_start = layered_ ? !chunk_started_ : !decoder_;
    if (at_chunk_start && chunk_ < table_->size() && (*table_)[chunk_].points <= count) {
      const ChunkEntry& entry = (*table_)[chunk_];
      const std::uint64_t end = bytes_.position() + entry.bytes;
      bytes_.set_limit(end);
      try {
        bytes_.skip_to(end);
      } catch (const ChunkOverrun&) {
        chunk_start_ = bytes_.position();
        fail_chunk("is truncated: the file ends inside it");
      }
      decoded_ += entry.points;
      count -= entry.points;
      ++chunk_;
    } else {
      read(scratch.data(), 1);
      --count;
    }
  }
  return true;
}

void LazRecordReader::read(char* out, std::size_t count) {
  auto* records = reinterpret_cast<std::uint8_t*>(out);
  for (std::size_t i = 0; i < count; ++i) {
    if (decoded_ >= points_) detail::fail(file_, "more LAZ points read than the header declares");
    std::uint8_t* record = records + i * record_length_;
    try {
      if (layered_) {
        if (!chunk_started_) {
          start_chunk();
          if (left_in_chunk_ == 0) fail_chunk("holds no points");
          start_layered_chunk(record);
          chunk_started_ = true;
        } else {
          layered_->decode(record);
        }
      } else if (!decoder_) {
        start_chunk();
        if (left_in_chunk_ == 0) fail_chunk("holds no points");
        bytes_.get(record, record_length_);
        for (std::size_t k = 0; k < items_.size(); ++k) items_[k]->start(record + item_offsets_[k]);
        decoder_.emplace(bytes_);
        decoder_->start();
      } else {
        for (std::size_t k = 0; k < items_.size(); ++k) items_[k]->decode(*decoder_, record + item_offsets_[k]);
      }
    } catch (const ChunkOverrun&) {
      if (table_) fail_chunk("is corrupt: its points need more than the " + std::to_string((*table_)[chunk_].bytes) + " bytes the chunk table gives it");
      fail_chunk("is truncated: its points run past the end of the file's point data");
    } catch (const CorruptCode&) {
      fail_chunk("is corrupt: its compressed values fall outside the range coder's interval");
    }
    ++decoded_;
    if (--left_in_chunk_ == 0) finish_chunk();
  }
}

}  // namespace pointfair::io::laz
