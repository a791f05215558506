#include "pointfair/io/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <random>
#include <string>
#include <system_error>
#include <utility>

#include "io_error.hpp"

namespace pointfair::io {

namespace fs = std::filesystem;
using detail::fail;
using detail::system_error_text;

FileSink::FileSink(std::FILE* file, fs::path name) : file_(file), name_(std::move(name)) {}

void FileSink::write(const void* data, std::size_t size) {
  if (size == 0) return;
  if (std::fwrite(data, 1, size, file_) != size) {
    const int error = errno != 0 ? errno : EIO;
    fail(name_, "write failed: " + system_error_text(error));
  }
}

void FileSink::flush() {
  if (std::fflush(file_) != 0) {
    const int error = errno != 0 ? errno : EIO;
    fail(name_, "write failed: " + system_error_text(error));
  }
}

namespace {

std::string random_suffix() {
  static thread_local std::mt19937_64 engine{std::random_device{}()};
  constexpr char digits[] = "0123456789abcdef";
  std::uint64_t bits = engine();
  std::string text;
  for (int i = 0; i < 12; ++i, bits >>= 4) text += digits[bits & 0xF];
  return text;
}

// Creates the temporary exclusively, so two writers can never share one.
int create_temporary(const fs::path& target, fs::path& temporary) {
  const fs::path directory = target.has_parent_path() ? target.parent_path() : fs::path(".");
  // Built with append: GCC 12 reports a false -Wrestrict for "." + std::string.
  std::string stem(1, '.');
  stem.append(target.filename().string()).append(".tmp-");
  stem.append(std::to_string(::getpid())).append("-");
  for (int attempt = 0; attempt < 16; ++attempt) {
    temporary = directory / (stem + random_suffix());
    const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) return fd;
    if (errno != EEXIST) fail(target, "cannot create file: " + system_error_text(errno));
  }
  fail(target, "cannot create a unique temporary file");
}

// Makes the rename itself durable; a failure here loses nothing already written.
void sync_directory(const fs::path& target) {
  const fs::path directory = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const int fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

void write_file_atomically(const fs::path& target,
                           const std::function<void(FileSink&)>& write_body) {
  if (target.filename().empty()) fail(target, "not a file name");
  struct stat existing {};
  const bool target_exists = ::stat(target.c_str(), &existing) == 0;
  if (target_exists && S_ISDIR(existing.st_mode)) {
    fail(target, "cannot write: " + system_error_text(EISDIR));
  }

  fs::path temporary;
  const int fd = create_temporary(target, temporary);
  if (target_exists) ::fchmod(fd, existing.st_mode & 07777);
  std::FILE* file = ::fdopen(fd, "wb");
  if (file == nullptr) {
    const int error = errno;
    ::close(fd);
    ::unlink(temporary.c_str());
    fail(target, "cannot create file: " + system_error_text(error));
  }

  try {
    FileSink sink(file, target);
    write_body(sink);
    sink.flush();
    // EINVAL: the file system cannot sync this kind of file, which is not a write error.
    if (::fsync(::fileno(file)) != 0 && errno != EINVAL) {
      fail(target, "write failed: " + system_error_text(errno));
    }
  } catch (...) {
    std::fclose(file);
    ::unlink(temporary.c_str());
    throw;
  }
  // fclose can report a delayed write error (e.g. on network file systems).
  if (std::fclose(file) != 0) {
    const int error = errno;
    ::unlink(temporary.c_str());
    fail(target, "write failed: " + system_error_text(error));
  }
  if (::rename(temporary.c_str(), target.c_str()) != 0) {
    const int error = errno;
    ::unlink(temporary.c_str());
    fail(target, "cannot replace file: " + system_error_text(error));
  }
  sync_directory(target);
}

void require_distinct(const fs::path& input, const fs::path& output) {
  std::error_code error;
  if (fs::exists(output, error)) {
    if (fs::equivalent(input, output, error) && !error) {
      fail(output, "output would overwrite the input");
    }
    return;
  }
  const auto normal = [](const fs::path& path) {
    std::error_code ignored;
    const fs::path absolute = fs::absolute(path, ignored);
    return (absolute.empty() ? path : absolute).lexically_normal();
  };
  if (normal(input) == normal(output)) fail(output, "output would overwrite the input");
}

}  // namespace pointfair::io
