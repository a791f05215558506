#include "io_error.hpp"

#include <system_error>

namespace pointfair::io::detail {

std::string error_message(const std::filesystem::path& file, std::string_view problem) {
  std::string message = file.string();
  message += ": ";
  message += problem;
  // Callers print what() as one log line; a file name or token with a line break must not
  // split it.
  for (char& c : message) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return message;
}

void fail(const std::filesystem::path& file, std::string_view problem) {
  throw IoError(error_message(file, problem));
}

std::string system_error_text(int error_number) {
  return std::generic_category().message(error_number);
}

void warn(const ReadOptions& options, const std::filesystem::path& file, std::string_view message) {
  if (options.on_warning) options.on_warning(error_message(file, message));
}

}  // namespace pointfair::io::detail
