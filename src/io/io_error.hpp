#pragma once
// Internal helpers that build the one-line "<file>: <problem>" messages of IoError.
#include <filesystem>
#include <string>
#include <string_view>

#include "pointfair/io/point_table.hpp"

namespace pointfair::io::detail {

/// "<file>: <problem>" with any line breaks replaced, so the message stays on one line.
std::string error_message(const std::filesystem::path& file, std::string_view problem);

/// Throws IoError(error_message(file, problem)).
[[noreturn]] void fail(const std::filesystem::path& file, std::string_view problem);

/// Text for an errno value, e.g. "No such file or directory".
std::string system_error_text(int error_number);

/// Passes error_message(file, message) to options.on_warning, if set.
void warn(const ReadOptions& options, const std::filesystem::path& file, std::string_view message);

}  // namespace pointfair::io::detail
