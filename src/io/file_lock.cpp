#include "pointfair/io/file_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>
#include <vector>

#include "file_reader.hpp"
#include "io_error.hpp"

namespace pointfair::io {

namespace fs = std::filesystem;
using detail::fail;
using detail::system_error_text;

namespace {

constexpr std::uint64_t kLockedByte = std::uint64_t{1} << 62;

constexpr const char* kInUse =
    "in use by another process (a run holds its lock): wait for that run to end, or stop it; two runs "
    "never share one run file";

bool same_file(int fd, const fs::path& path) {
  struct stat by_fd {}, by_path {};
  return ::fstat(fd, &by_fd) == 0 && ::stat(path.c_str(), &by_path) == 0 && by_fd.st_dev == by_path.st_dev &&
         by_fd.st_ino == by_path.st_ino;
}

}  // namespace

FileLock::FileLock(fs::path path) : path_(std::move(path)) {
  // Another process may rename or remove the file between our open and our lock (a run that
  // finishes renames its run file into place): then the lock is on a file no longer at
  // `path`, and we try again.
  for (int attempt = 0; attempt < 8; ++attempt) {
    created_ = false;
    fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd_ >= 0) {
      created_ = true;
    } else if (errno == EEXIST) {
      fd_ = ::open(path_.c_str(), O_RDWR | O_CLOEXEC | O_NONBLOCK);
      if (fd_ < 0 && errno == ENOENT) continue;
    }
    if (fd_ < 0) fail(path_, "cannot lock: " + system_error_text(errno));
    struct stat info {};
    if (::fstat(fd_, &info) != 0 || !S_ISREG(info.st_mode)) {
      ::close(fd_);
      fd_ = -1;
      fail(path_, "exists and is not a regular file: refused");
    }
    // One byte far beyond any data (2^62): MPI-IO (ROMIO) takes fcntl locks on the ranges it
    // writes, which an OFD lock on the whole file would block, ranks of the same run
    // included. Two locks of this byte still exclude each other.
    struct flock lock {};
    lock.l_type = F_WRLCK;
    lock.l_whence = SEEK_SET;
    lock.l_start = static_cast<off_t>(kLockedByte);
    lock.l_len = 1;
    if (::fcntl(fd_, F_OFD_SETLK, &lock) != 0) {
      const int error = errno;
      ::close(fd_);
      fd_ = -1;
      if (error == EAGAIN || error == EACCES) fail(path_, kInUse);
      fail(path_, "cannot lock: " + system_error_text(error));
    }
    if (same_file(fd_, path_)) {
      size_ = static_cast<std::uint64_t>(info.st_size);
      return;
    }
    ::close(fd_);
    fd_ = -1;
  }
  fail(path_, "cannot lock: the file keeps being replaced by another process");
}

FileLock::~FileLock() {
  if (fd_ >= 0) ::close(fd_);
}

FolderLock::FolderLock(fs::path path) : path_(std::move(path)) {
  fd_ = ::open(path_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd_ < 0) fail(path_, "cannot lock: " + system_error_text(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    ::close(fd_);
    fd_ = -1;
    if (error == EWOULDBLOCK) fail(path_, kInUse);
    fail(path_, "cannot lock: " + system_error_text(error));
  }
  if (!same_file(fd_, path_)) {
    ::close(fd_);
    fd_ = -1;
    fail(path_, "cannot lock: the folder was removed or replaced by another process");
  }
}

FolderLock::~FolderLock() {
  if (fd_ >= 0) ::close(fd_);
}

void require_regular_input(const fs::path& path) { detail::require_regular_input(path); }

std::uint64_t digest_update(std::uint64_t state, const void* data, std::size_t size) {
  // Eight bytes at a time, each word mixed in with a multiply and a rotation (the tail is
  // padded with zeros and the length mixed in last).
  const auto* bytes = static_cast<const unsigned char*>(data);
  constexpr std::uint64_t kMultiplier = 0xff51afd7ed558ccdull;
  std::size_t i = 0;
  for (; i + 8 <= size; i += 8) {
    std::uint64_t word;
    std::memcpy(&word, bytes + i, 8);
    state = ((state ^ word) * kMultiplier);
    state ^= state >> 29;
  }
  if (i < size) {
    std::uint64_t word = 0;
    std::memcpy(&word, bytes + i, size - i);
    state = ((state ^ word) * kMultiplier);
    state ^= state >> 29;
  }
  state = (state ^ size) * 0xc4ceb9fe1a85ec53ull;
  return state ^ (state >> 32);
}

std::string digest_text(std::uint64_t state) {
  constexpr char digits[] = "0123456789abcdef";
  std::string text(16, '0');
  for (int i = 15; i >= 0; --i, state >>= 4) text[static_cast<std::size_t>(i)] = digits[state & 0xF];
  return text;
}

std::string file_digest(const fs::path& path) {
  detail::FileReader reader(path);
  std::vector<char> block(std::size_t{1} << 20);
  std::uint64_t state = kDigestSeed;
  for (;;) {
    const std::size_t got = reader.read(block.data(), block.size());
    if (got == 0) break;
    state = digest_update(state, block.data(), got);
  }
  return digest_text(state);
}

}  // namespace pointfair::io
