#pragma once
// Files written under a temporary name beside their target, then renamed into place.
#include <filesystem>
#include <system_error>

#include "pointfair/io/point_table.hpp"

namespace pointfair::tiles {

/// ".<target's name><kind><pid>-<random>" in the target's folder; `kind` e.g. ".tmp-".
std::filesystem::path temporary_name(const std::filesystem::path& target, const char* kind = ".tmp-");

/// Removes `path` (quietly) when it goes out of scope, unless cleared first.
struct RemoveOnExit {
  std::filesystem::path path;
  ~RemoveOnExit() {
    std::error_code ec;
    if (!path.empty()) std::filesystem::remove(path, ec);
  }
};

/// `error` with every temporary of `target` (temporary_name) it names named as `target`
/// instead: errors name the file the user asked for.
io::IoError naming_target(const io::IoError& error, const std::filesystem::path& target);

}  // namespace pointfair::tiles
