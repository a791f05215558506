#pragma once
// Internal conversion between the in-memory doubles and a file's stored scalar types,
// column by column over blocks of fixed-size binary records. The type and byte order are
// resolved once per column, so the inner loops are plain copies.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include "pointfair/io/point_table.hpp"

namespace pointfair::io::detail {

/// Calls `f(T{})` with the C++ type that stores `type`.
template <typename F>
void visit_scalar(ScalarType type, F&& f) {
  switch (type) {
    case ScalarType::Int8:
      f(std::int8_t{});
      return;
    case ScalarType::UInt8:
      f(std::uint8_t{});
      return;
    case ScalarType::Int16:
      f(std::int16_t{});
      return;
    case ScalarType::UInt16:
      f(std::uint16_t{});
      return;
    case ScalarType::Int32:
      f(std::int32_t{});
      return;
    case ScalarType::UInt32:
      f(std::uint32_t{});
      return;
    case ScalarType::Float32:
      f(float{});
      return;
    case ScalarType::Float64:
      f(double{});
      return;
  }
}

constexpr bool is_integer_type(ScalarType type) {
  return type != ScalarType::Float32 && type != ScalarType::Float64;
}

/// Nearest value of T to `value`: integers round half away from zero and saturate (NaN
/// becomes 0); floating types convert.
template <typename T>
T to_stored(double value) {
  if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(value);
  } else {
    if (std::isnan(value)) return T{0};
    const double rounded = std::round(value);
    constexpr auto lowest = std::numeric_limits<T>::lowest();
    constexpr auto highest = std::numeric_limits<T>::max();
    if (rounded <= static_cast<double>(lowest)) return lowest;
    if (rounded >= static_cast<double>(highest)) return highest;
    return static_cast<T>(rounded);
  }
}

/// True if `value` is exactly representable in `type` (integral and in range for integers).
inline bool fits_type(ScalarType type, double value) {
  bool fits = true;
  visit_scalar(type, [&](auto tag) {
    using T = decltype(tag);
    if constexpr (!std::is_floating_point_v<T>) {
      fits = value == std::trunc(value) &&
             value >= static_cast<double>(std::numeric_limits<T>::lowest()) &&
             value <= static_cast<double>(std::numeric_limits<T>::max());
    }
  });
  return fits;
}

template <typename T, bool Swap>
T load_scalar(const char* bytes) {
  std::array<char, sizeof(T)> raw;
  std::memcpy(raw.data(), bytes, sizeof(T));
  if constexpr (Swap) std::reverse(raw.begin(), raw.end());
  T value;
  std::memcpy(&value, raw.data(), sizeof(T));
  return value;
}

template <typename T, bool Swap>
void store_scalar(T value, char* bytes) {
  std::array<char, sizeof(T)> raw;
  std::memcpy(raw.data(), &value, sizeof(T));
  if constexpr (Swap) std::reverse(raw.begin(), raw.end());
  std::memcpy(bytes, raw.data(), sizeof(T));
}

/// Whether values stored in the given byte order must be byte-swapped on this machine.
constexpr bool needs_swap(bool file_is_big_endian) {
  return file_is_big_endian != (std::endian::native == std::endian::big);
}

/// Decodes one column of `count` records (`stride` bytes apart, the column at `records`)
/// into out[0], out[out_stride], ...
inline void decode_column(ScalarType type, bool swap, const char* records, std::size_t stride,
                          std::size_t count, double* out, std::size_t out_stride) {
  visit_scalar(type, [&](auto tag) {
    using T = decltype(tag);
    if (swap) {
      for (std::size_t i = 0; i < count; ++i) {
        out[i * out_stride] = static_cast<double>(load_scalar<T, true>(records + i * stride));
      }
    } else {
      for (std::size_t i = 0; i < count; ++i) {
        out[i * out_stride] = static_cast<double>(load_scalar<T, false>(records + i * stride));
      }
    }
  });
}

/// Encodes in[0], in[in_stride], ... into one column of `count` records.
inline void encode_column(ScalarType type, bool swap, const double* in, std::size_t in_stride,
                          std::size_t count, char* records, std::size_t stride) {
  visit_scalar(type, [&](auto tag) {
    using T = decltype(tag);
    if (swap) {
      for (std::size_t i = 0; i < count; ++i) {
        store_scalar<T, true>(to_stored<T>(in[i * in_stride]), records + i * stride);
      }
    } else {
      for (std::size_t i = 0; i < count; ++i) {
        store_scalar<T, false>(to_stored<T>(in[i * in_stride]), records + i * stride);
      }
    }
  });
}

}  // namespace pointfair::io::detail
