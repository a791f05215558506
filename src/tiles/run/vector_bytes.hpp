#pragma once
// The memory a vector holds, and giving it back: the out-of-core run's accounting of its
// working buffers.
#include <cstdint>
#include <vector>

namespace pointfair::tiles::detail {

// Empties a vector and gives its memory back (`v = {}` would keep the capacity: it assigns
// an empty initializer list).
template <class T>
void free_vector(std::vector<T>& v) {
  std::vector<T>().swap(v);
}

// Bytes held by a vector.
template <class T>
std::uint64_t bytes(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}

}  // namespace pointfair::tiles::detail
