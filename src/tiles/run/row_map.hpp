#pragma once
// Container row -> local index of a tile in flight, for the rows outside the tile (its rings).
// Open addressing with linear probing: a temporal block looks up every entry of its lists,
// millions of times a block, where a binary search over the sorted rows cost a third of the
// run. Internal: not installed.
#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair::tiles {

class RowMap {
 public:
  RowMap() { reset(0); }

  /// Empties the map and makes room for about `expected` rows without growing.
  void reset(std::size_t expected) {
    const std::size_t capacity = std::bit_ceil(std::max<std::size_t>(16, 2 * expected));
    keys_.assign(capacity, kEmpty);
    values_.resize(capacity);
    size_ = 0;
    shift_ = 64 - std::countr_zero(capacity);
  }

  /// The local index of `row`, or null.
  const Index* find(std::uint64_t row) const {
    for (std::size_t i = slot(row);; i = (i + 1) & (keys_.size() - 1)) {
      if (keys_[i] == row) return &values_[i];
      if (keys_[i] == kEmpty) return nullptr;
    }
  }

  /// Adds `row` -> `local` unless `row` is present; true if it was added.
  bool insert(std::uint64_t row, Index local) {
    if (2 * (size_ + 1) > keys_.size()) grow();
    for (std::size_t i = slot(row);; i = (i + 1) & (keys_.size() - 1)) {
      if (keys_[i] == row) return false;
      if (keys_[i] == kEmpty) {
        keys_[i] = row;
        values_[i] = local;
        ++size_;
        return true;
      }
    }
  }

  /// Sets the local index of a present row.
  void set(std::uint64_t row, Index local) {
    for (std::size_t i = slot(row);; i = (i + 1) & (keys_.size() - 1)) {
      if (keys_[i] == row) {
        values_[i] = local;
        return;
      }
    }
  }

  /// An upper bound of bytes() per row held (at most a quarter of the slots are taken after
  /// a reset, half before it grows).
  static constexpr std::uint64_t kBytesPerRow = 4 * (sizeof(std::uint64_t) + sizeof(Index));

  std::uint64_t bytes() const { return keys_.capacity() * sizeof(std::uint64_t) + values_.capacity() * sizeof(Index); }

 private:
  static constexpr std::uint64_t kEmpty = std::numeric_limits<std::uint64_t>::max();

  std::size_t slot(std::uint64_t row) const {
    return static_cast<std::size_t>((row * 0x9E3779B97F4A7C15ull) >> shift_);
  }

  void grow() {
    std::vector<std::uint64_t> keys;
    std::vector<Index> values;
    keys.swap(keys_);
    values.swap(values_);
    reset(keys.size());
    for (std::size_t i = 0; i < keys.size(); ++i)
      if (keys[i] != kEmpty) insert(keys[i], values[i]);
  }

  std::vector<std::uint64_t> keys_;
  std::vector<Index> values_;
  std::size_t size_ = 0;
  int shift_ = 64;
};

}  // namespace pointfair::tiles
