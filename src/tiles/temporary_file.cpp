#include "temporary_file.hpp"

#include <unistd.h>

#include <random>
#include <string>

namespace pointfair::tiles {

namespace fs = std::filesystem;

fs::path temporary_name(const fs::path& target, const char* kind) {
  std::random_device rd;
  // A name nothing has: the pid and a random number, drawn again while a file has it.
  for (;;) {
    std::string name = std::string(".") + target.filename().string();
    name += std::string(kind) + std::to_string(::getpid());
    name += std::string("-") + std::to_string(rd());
    fs::path candidate = target.parent_path() / name;
    std::error_code ec;
    if (!fs::exists(fs::symlink_status(candidate, ec))) return candidate;
  }
}

io::IoError naming_target(const io::IoError& error, const fs::path& target) {
  // A temporary's name runs from this prefix to the ": " that ends it in a message.
  std::string hidden = ".";
  hidden += target.filename().string();
  hidden += '.';
  const std::string prefix = (target.parent_path() / hidden).string();
  std::string message = error.what();
  for (std::size_t at = message.find(prefix); at != std::string::npos;
       at = message.find(prefix, at + target.string().size())) {
    const std::size_t end = message.find(':', at);
    if (end == std::string::npos) break;
    message.replace(at, end - at, target.string());
  }
  return io::IoError(message);
}

}  // namespace pointfair::tiles
