#include "number_text.hpp"

#include <charconv>
#include <cmath>
#include <limits>
#include <system_error>

namespace pointfair::io::detail {

namespace {

// from_chars rejects a leading '+', which other tools do write.
std::string_view strip_plus(std::string_view text) {
  if (text.size() > 1 && text.front() == '+' && text[1] != '-' && text[1] != '+') {
    text.remove_prefix(1);
  }
  return text;
}

// After from_chars reported result_out_of_range the text is a valid number whose magnitude
// is too large or too small: a negative exponent means it underflowed.
double out_of_range_value(std::string_view text) {
  const bool negative = !text.empty() && text.front() == '-';
  const std::size_t exponent = text.find_first_of("eE");
  const bool underflow =
      exponent != std::string_view::npos && exponent + 1 < text.size() && text[exponent + 1] == '-';
  const double magnitude = underflow ? 0.0 : std::numeric_limits<double>::infinity();
  return negative ? -magnitude : magnitude;
}

template <typename T>
bool parse_floating(std::string_view text, T& value) {
  text = strip_plus(text);
  if (text.empty()) return false;
  T parsed{};
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), parsed);
  if (end != text.data() + text.size()) return false;
  if (error == std::errc::result_out_of_range) {
    value = static_cast<T>(out_of_range_value(text));
    return true;
  }
  if (error != std::errc{}) return false;
  value = parsed;
  return true;
}

template <typename T>
void append_chars(std::string& out, T value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, result.ptr);
}

}  // namespace

bool parse_double(std::string_view text, double& value) { return parse_floating(text, value); }
bool parse_float(std::string_view text, float& value) { return parse_floating(text, value); }

void append_number(std::string& out, double value) { append_chars(out, value); }
void append_number(std::string& out, float value) { append_chars(out, value); }
void append_integer(std::string& out, std::int64_t value) { append_chars(out, value); }

std::string_view non_finite_name(double value) {
  if (std::isnan(value)) return "nan";
  return value > 0 ? "inf" : "-inf";
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && is_space(text.front())) text.remove_prefix(1);
  while (!text.empty() && is_space(text.back())) text.remove_suffix(1);
  return text;
}

std::string_view next_token(std::string_view& rest) {
  std::size_t start = 0;
  while (start < rest.size() && is_space(rest[start])) ++start;
  std::size_t end = start;
  while (end < rest.size() && !is_space(rest[end])) ++end;
  const std::string_view token = rest.substr(start, end - start);
  rest.remove_prefix(end);
  return token;
}

}  // namespace pointfair::io::detail
