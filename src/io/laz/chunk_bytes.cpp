#include "laz/chunk_bytes.hpp"

#include <algorithm>
#include <cassert>

namespace pointfair::io::laz {

namespace {
constexpr std::uint64_t kBlockBytes = 64 * 1024;
}

void ChunkBytes::set_limit(std::uint64_t limit) {
  limit_ = limit;
  const std::uint64_t here = position();
  const std::uint64_t allowed = limit > here ? limit - here : 0;
  stop_ = next_ + static_cast<std::size_t>(std::min<std::uint64_t>(allowed, end_ - next_));
}

void ChunkBytes::refill() {
  assert(next_ == stop_);
  if (stop_ < end_ || reader_ == nullptr) throw ChunkOverrun{};  // the limit lies inside the buffered bytes
  const std::uint64_t wanted = limit_ > buffer_end_position_ ? std::min(kBlockBytes, limit_ - buffer_end_position_) : 0;
  if (wanted == 0) throw ChunkOverrun{};
  buffer_.resize(static_cast<std::size_t>(wanted));
  const std::size_t got = reader_->read(reinterpret_cast<char*>(buffer_.data()), buffer_.size());
  if (got == 0) throw ChunkOverrun{};
  next_ = 0;
  stop_ = end_ = got;
  buffer_end_position_ += got;
}

void ChunkBytes::skip_to(std::uint64_t target) {
  assert(target >= position() && target <= limit_);
  const std::uint64_t distance = target - position();
  if (distance <= end_ - next_) {
    next_ += static_cast<std::size_t>(distance);
    return;
  }
  const std::uint64_t beyond = distance - (end_ - next_);
  next_ = end_ = stop_ = 0;
  if (reader_ == nullptr || reader_->skip(beyond) != beyond) throw ChunkOverrun{};
  buffer_end_position_ += beyond;
}

}  // namespace pointfair::io::laz
