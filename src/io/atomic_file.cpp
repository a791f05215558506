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

void FileSink::write_at(std::uint64_t offset, std::string_view bytes) {
  flush();
  if (::fseeko(file_, static_cast<off_t>(offset), SEEK_SET) != 0) {
    fail(name_, "write failed: " + system_error_text(errno));
  }
  write(bytes);
  flush();
  if (::fseeko(file_, 0, SEEK_END) != 0) fail(name_, "write failed: " + system_error_text(errno));
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

void require_output_path(const fs::path& output) {
  struct stat existing {};
  if (::stat(output.c_str(), &existing) != 0) return;
  if (S_ISDIR(existing.st_mode)) fail(output, "cannot write: " + system_error_text(EISDIR));
  if (S_ISREG(existing.st_mode)) return;
  const char* kind = S_ISFIFO(existing.st_mode)  ? "a named pipe"
                     : S_ISCHR(existing.st_mode) ? "a character device"
                     : S_ISBLK(existing.st_mode) ? "a block device"
                     : S_ISSOCK(existing.st_mode) ? "a socket"
                                                  : "not a file";
  fail(output, std::string("exists and is not a regular file (") + kind +
                   "): refused; outputs replace regular files only");
}

AtomicFile::AtomicFile(fs::path target) : target_(std::move(target)) {
  if (target_.filename().empty()) fail(target_, "not a file name");
  require_output_path(target_);
  struct stat existing {};
  const bool target_exists = ::stat(target_.c_str(), &existing) == 0;
  const int fd = create_temporary(target_, temporary_);
  if (target_exists) ::fchmod(fd, existing.st_mode & 07777);
  file_ = ::fdopen(fd, "wb");
  if (file_ == nullptr) {
    const int error = errno;
    ::close(fd);
    ::unlink(temporary_.c_str());
    fail(target_, "cannot create file: " + system_error_text(error));
  }
  sink_.emplace(file_, target_);
}

AtomicFile::~AtomicFile() { abandon(); }

void AtomicFile::abandon() {
  if (file_ == nullptr) return;
  std::fclose(file_);
  file_ = nullptr;
  ::unlink(temporary_.c_str());
}

void AtomicFile::commit() {
  try {
    sink_->flush();
    // EINVAL: the file system cannot sync this kind of file, which is not a write error.
    if (::fsync(::fileno(file_)) != 0 && errno != EINVAL) {
      fail(target_, "write failed: " + system_error_text(errno));
    }
  } catch (...) {
    abandon();
    throw;
  }
  // fclose can report a delayed write error (e.g. on network file systems).
  const int closed = std::fclose(file_);
  file_ = nullptr;
  if (closed != 0) {
    const int error = errno;
    ::unlink(temporary_.c_str());
    fail(target_, "write failed: " + system_error_text(error));
  }
  if (::rename(temporary_.c_str(), target_.c_str()) != 0) {
    const int error = errno;
    ::unlink(temporary_.c_str());
    fail(target_, "cannot replace file: " + system_error_text(error));
  }
  sync_directory(target_);
}

void write_file_atomically(const fs::path& target,
                           const std::function<void(FileSink&)>& write_body) {
  AtomicFile file(target);
  write_body(file.sink());
  file.commit();
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
