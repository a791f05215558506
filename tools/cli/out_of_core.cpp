#include "out_of_core.hpp"

#include <cctype>
#include <charconv>
#include <string>

#include "arguments.hpp"
#include "pointfair/io/file_lock.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/io/point_folder.hpp"

namespace pointfair::cli {

std::uint64_t parse_size(std::string_view text, std::string_view what) {
  std::uint64_t value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  std::string unit(ptr, end);
  for (char& c : unit) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (unit.ends_with("IB")) unit.resize(unit.size() - 2);
  else if (unit.size() == 2 && unit.back() == 'B') unit.resize(1);
  int shift = -1;
  if (unit.empty() || unit == "B") shift = 0;
  else if (unit == "K") shift = 10;
  else if (unit == "M") shift = 20;
  else if (unit == "G") shift = 30;
  else if (unit == "T") shift = 40;
  if (text.empty() || ec != std::errc() || ptr == text.data() || shift < 0 || value == 0 ||
      value > (std::uint64_t{1} << (63 - shift)))
    throw UsageError(std::string(what) + " expects a positive size such as 256M or 2G, got '" +
                     std::string(text) + "'");
  return value << shift;
}

std::uint64_t input_file_size(const std::filesystem::path& file) {
  if (std::filesystem::is_directory(file)) {
    std::uint64_t total = 0;
    for (const auto& f : io::point_files_in(file)) total += input_file_size(f);
    return total;
  }
  io::require_regular_input(file);
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(file, ec);
  if (ec) throw io::IoError(file.string() + ": cannot open: " + ec.message());
  return size;
}

}  // namespace pointfair::cli
