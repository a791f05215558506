#pragma once
// Internal locale-independent number parsing and shortest round-trip formatting.
#include <cstdint>
#include <string>
#include <string_view>

namespace pointfair::io::detail {

/// Parses the whole of `text` as a decimal number (optional sign, "nan", "inf" accepted).
/// Values beyond the range of double become +-inf or +-0. False if `text` is not a number.
bool parse_double(std::string_view text, double& value);
/// As parse_double, rounding correctly to float.
bool parse_float(std::string_view text, float& value);

/// Appends the shortest text that reads back as exactly `value`.
void append_number(std::string& out, double value);
void append_number(std::string& out, float value);
void append_integer(std::string& out, std::int64_t value);

/// "nan", "inf" or "-inf" for a non-finite value (for error messages).
std::string_view non_finite_name(double value);

/// Whitespace as separators in text point files: space, tab, CR, vertical tab, form feed.
constexpr bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/// `text` without leading and trailing whitespace.
std::string_view trim(std::string_view text);

/// Removes and returns the next whitespace-separated token of `rest`; empty at the end.
std::string_view next_token(std::string_view& rest);

}  // namespace pointfair::io::detail
