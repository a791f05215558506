#pragma once
// Large arrays read at random places (the cell grid's coordinates, which every query reads
// around its cell) miss the TLB on almost every access with 4 KiB pages. On Linux, such an
// array asks for transparent huge pages before its pages are first touched. An array written
// once and read in order gains little and pays the huge pages' first touch (the neighbour
// lists, knn_grid.cpp). Internal: not installed.
#include <cstddef>
#include <vector>

namespace pointfair::detail {

/// Advises the kernel to back the whole 2 MiB pages within [data, data + bytes) with huge
/// pages. Only a hint: nothing happens where the system does not support it.
void advise_huge_pages(void* data, std::size_t bytes);

/// v.assign(n, value), its storage advised for huge pages before it is first written.
template <class T>
void assign_huge(std::vector<T>& v, std::size_t n, const T& value) {
  if (v.capacity() < n) {
    std::vector<T>().swap(v);
    v.reserve(n);
    advise_huge_pages(v.data(), n * sizeof(T));
  }
  v.assign(n, value);
}

}  // namespace pointfair::detail
