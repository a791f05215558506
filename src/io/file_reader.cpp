#include "file_reader.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string>
#include <utility>

#include "io_error.hpp"

namespace pointfair::io::detail {

namespace {
constexpr std::size_t kBufferSize = std::size_t{1} << 20;
// The longest line read: a text line of 65,535 attributes of 25 characters each fits many
// times over; more is not a point file (e.g. binary data under a text file's name).
constexpr std::size_t kMaxLine = std::size_t{16} << 20;
}

std::string non_regular_kind(unsigned mode) {
  return S_ISFIFO(mode)  ? "a named pipe"
         : S_ISCHR(mode) ? "a character device"
         : S_ISBLK(mode) ? "a block device"
         : S_ISSOCK(mode) ? "a socket"
         : S_ISDIR(mode)  ? "a folder"
                          : "not a regular file";
}

void require_regular_input(const std::filesystem::path& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) return;  // the open that follows names the reason
  if (S_ISDIR(info.st_mode)) fail(path, "cannot open: " + system_error_text(EISDIR));
  if (!S_ISREG(info.st_mode))
    fail(path, "is " + non_regular_kind(info.st_mode) +
                   ", not a regular file: inputs are read from regular files (copy it to one first)");
}

FileReader::FileReader(std::filesystem::path path) : path_(std::move(path)) {
  // Opened without blocking, so that a named pipe with no writer cannot hang the open; only a
  // regular file is read (a pipe or /dev/zero has no size to check counts against, and may
  // never end).
  const int fd = ::open(path_.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) fail(path_, "cannot open: " + system_error_text(errno));
  struct stat info {};
  if (::fstat(fd, &info) != 0) {
    const int error = errno;
    ::close(fd);
    fail(path_, "cannot open: " + system_error_text(error));
  }
  if (S_ISDIR(info.st_mode)) {
    ::close(fd);
    fail(path_, "cannot open: " + system_error_text(EISDIR));
  }
  if (!S_ISREG(info.st_mode)) {
    ::close(fd);
    fail(path_, "is " + non_regular_kind(info.st_mode) +
                    ", not a regular file: inputs are read from regular files (copy it to one first)");
  }
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  file_ = ::fdopen(fd, "rb");
  if (file_ == nullptr) {
    const int error = errno;
    ::close(fd);
    fail(path_, "cannot open: " + system_error_text(error));
  }
  size_ = static_cast<std::uint64_t>(info.st_size);
  // This class does its own buffering; a second stdio buffer would only add copies.
  std::setvbuf(file_, nullptr, _IONBF, 0);
  // A small file gets a small buffer (refill() grows it for a long line or a growing file).
  buffer_.resize(static_cast<std::size_t>(std::clamp<std::uint64_t>(size_ + 1, 4096, kBufferSize)));
}

FileReader::~FileReader() { std::fclose(file_); }

std::size_t FileReader::read_from_file(char* out, std::size_t size) {
  const std::size_t got = std::fread(out, 1, size, file_);
  if (got < size && std::ferror(file_)) {
    fail(path_, "read failed: " + system_error_text(errno != 0 ? errno : EIO));
  }
  read_total_ += got;
  // The end of the file before the size it had when opened: cut while being read. Without
  // this check a text file cut at a line break would read as a shorter, valid file.
  if (got < size && read_total_ < size_) {
    fail(path_, "file shrank while being read (" + std::to_string(size_) + " bytes when opened, " +
                    std::to_string(read_total_) + " found)");
  }
  return got;
}

bool FileReader::refill() {
  if (begin_ > 0) {
    std::copy(buffer_.begin() + static_cast<std::ptrdiff_t>(begin_),
              buffer_.begin() + static_cast<std::ptrdiff_t>(end_), buffer_.begin());
    end_ -= begin_;
    begin_ = 0;
  }
  if (end_ == buffer_.size()) {  // a very long line
    if (buffer_.size() >= kMaxLine)
      fail(path_, "line " + std::to_string(line_number_ + 1) + " is longer than " +
                      std::to_string(kMaxLine >> 20) + " MiB: not a text point file");
    buffer_.resize(buffer_.size() * 2);
  }
  const std::size_t got = read_from_file(buffer_.data() + end_, buffer_.size() - end_);
  end_ += got;
  return got > 0;
}

bool FileReader::next_line(std::string_view& line) {
  std::size_t scanned = 0;  // bytes after begin_ already known to hold no '\n'
  for (;;) {
    const char* start = buffer_.data() + begin_;
    const auto* newline =
        static_cast<const char*>(std::memchr(start + scanned, '\n', end_ - begin_ - scanned));
    std::size_t length = 0;
    std::size_t advance = 0;
    if (newline != nullptr) {
      length = static_cast<std::size_t>(newline - start);
      advance = length + 1;
    } else {
      scanned = end_ - begin_;
      if (refill()) continue;
      if (begin_ == end_) return false;
      length = end_ - begin_;  // last line without a final newline
      advance = length;
      start = buffer_.data() + begin_;
    }
    begin_ += advance;
    consumed_ += advance;
    ++line_number_;
    line_had_cr_ = length > 0 && start[length - 1] == '\r';
    if (line_had_cr_) --length;
    line = std::string_view(start, length);
    return true;
  }
}

std::size_t FileReader::read(char* out, std::size_t size) {
  const std::size_t buffered = std::min(size, end_ - begin_);
  std::copy_n(buffer_.data() + begin_, buffered, out);
  begin_ += buffered;
  std::size_t done = buffered;
  if (done < size) done += read_from_file(out + done, size - done);
  consumed_ += done;
  return done;
}

std::uint64_t FileReader::skip(std::uint64_t size) {
  const std::uint64_t buffered = std::min<std::uint64_t>(size, end_ - begin_);
  begin_ += static_cast<std::size_t>(buffered);
  std::uint64_t done = buffered;
  // Seek instead of reading what is skipped, but never past the known end of file.
  const std::uint64_t rest = std::min(size - done, remaining() - buffered);
  if (rest > 0) {
    if (::fseeko(file_, static_cast<off_t>(rest), SEEK_CUR) != 0) {
      fail(path_, "read failed: " + system_error_text(errno));
    }
    read_total_ += rest;  // the file position moved past these bytes
    done += rest;
  }
  consumed_ += done;
  return done;
}

}  // namespace pointfair::io::detail
