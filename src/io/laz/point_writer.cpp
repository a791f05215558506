#include "laz/point_writer.hpp"

#include <cassert>
#include <cstring>
#include <string>

namespace pointfair::io::laz {

LazRecordWriter::LazRecordWriter(FileSink& sink, const LaszipInfo& info, std::uint64_t point_data_start,
                                 std::size_t record_length)
    : sink_(sink), info_(info), record_length_(record_length), point_data_start_(point_data_start) {
  assert(info_.chunk_size > 0 && info_.chunk_size != kVariableChunkSize);
  if (info_.compressor == kLayeredChunked) {
    const std::size_t base = info_.items.size() > 1 && info_.items[1].type != ItemType::Byte14 ? 30 + info_.items[1].size : 30;
    layered_ = std::make_unique<Layered14Codec>(base == 30 ? 6 : base == 36 ? 7 : 8, record_length_ - base);
  } else {
    std::size_t offset = 0;
    for (const LazItem& item : info_.items) {
      items_.push_back(make_item_codec_v2(item));
      item_offsets_.push_back(offset);
      offset += item.size;
    }
    assert(offset == record_length_);
  }
  const std::int64_t placeholder = -1;
  sink_.write(&placeholder, 8);
  position_ = point_data_start_ + 8;
}

void LazRecordWriter::write(const char* records, std::size_t count) {
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(records);
  for (std::size_t i = 0; i < count; ++i) {
    const std::uint8_t* record = bytes + i * record_length_;
    if (layered_) {
      if (in_chunk_ == 0) {
        chunk_.assign(record, record + record_length_);
        layered_->start_encoding(record);
      } else {
        layered_->encode(record);
      }
    } else if (!encoder_) {
      // The chunk's first point is stored raw and starts every item's context.
      chunk_.assign(record, record + record_length_);
      for (std::size_t k = 0; k < items_.size(); ++k) items_[k]->start(record + item_offsets_[k]);
      encoder_.emplace(chunk_);
    } else {
      for (std::size_t k = 0; k < items_.size(); ++k) items_[k]->encode(*encoder_, record + item_offsets_[k]);
    }
    if (++in_chunk_ == info_.chunk_size) finish_chunk();
  }
}

void LazRecordWriter::finish_chunk() {
  if (layered_) {
    // The raw first record, the point count, the size of each layer, then the layers.
    const std::vector<std::vector<std::uint8_t>> layers = layered_->finish_encoding();
    auto put32 = [&](std::uint32_t value) {
      for (int b = 0; b < 4; ++b) chunk_.push_back(static_cast<std::uint8_t>(value >> (8 * b)));
    };
    put32(static_cast<std::uint32_t>(in_chunk_));
    for (const auto& layer : layers) put32(static_cast<std::uint32_t>(layer.size()));
    for (const auto& layer : layers) chunk_.insert(chunk_.end(), layer.begin(), layer.end());
  } else {
    encoder_->finish();
    encoder_.reset();
  }
  sink_.write(chunk_.data(), chunk_.size());
  table_.push_back({in_chunk_, chunk_.size()});
  position_ += chunk_.size();
  in_chunk_ = 0;
  chunk_.clear();
}

std::uint64_t LazRecordWriter::finish() {
  if (in_chunk_ > 0) finish_chunk();
  const std::string table = encode_chunk_table(table_, false);
  const auto table_offset = static_cast<std::int64_t>(position_);
  sink_.write(table);
  position_ += table.size();
  sink_.write_at(point_data_start_, std::string_view(reinterpret_cast<const char*>(&table_offset), 8));
  return position_;
}

}  // namespace pointfair::io::laz
