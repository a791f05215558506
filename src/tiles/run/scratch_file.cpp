#include "scratch_file.hpp"

#include <fcntl.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "pointfair/io/point_table.hpp"

namespace pointfair::tiles {

namespace {

// An unlinked file in `directory`: O_TMPFILE where the file system has it, else a named one
// removed at once. -1 with errno set when neither works.
int open_unlinked(const std::filesystem::path& directory) {
#ifdef O_TMPFILE
  const int fd = ::open(directory.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd >= 0) return fd;
#endif
  std::string pattern = (directory / ".pointfair-scratch-XXXXXX").string();
  const int named = ::mkstemp(pattern.data());
  if (named < 0) return -1;
  ::unlink(pattern.c_str());
  ::fcntl(named, F_SETFD, FD_CLOEXEC);
  return named;
}

}  // namespace

ScratchFile::ScratchFile(const std::filesystem::path& directory, std::string name) : name_(std::move(name)) {
  fd_ = open_unlinked(directory);
  if (fd_ < 0) throw io::IoError(name_ + ": cannot create: " + std::strerror(errno));
}

ScratchFile::~ScratchFile() {
  if (fd_ >= 0) ::close(fd_);
}

void ScratchFile::reserve(std::uint64_t bytes) {
  if (bytes == 0) return;
  const int e = ::posix_fallocate(fd_, 0, static_cast<off_t>(bytes));
  if (e != 0) throw io::IoError(name_ + ": cannot allocate " + std::to_string(bytes) + " bytes: " + std::strerror(e));
}

ScratchFile::Mapping::~Mapping() {
  if (base_ != nullptr) ::munmap(base_, length_);
}

ScratchFile::Mapping::Mapping(Mapping&& other) noexcept
    : base_(std::exchange(other.base_, nullptr)), length_(std::exchange(other.length_, 0)),
      data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)) {}

ScratchFile::Mapping& ScratchFile::Mapping::operator=(Mapping&& other) noexcept {
  if (this != &other) {
    if (base_ != nullptr) ::munmap(base_, length_);
    base_ = std::exchange(other.base_, nullptr);
    length_ = std::exchange(other.length_, 0);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
  }
  return *this;
}

ScratchFile::Mapping ScratchFile::map(std::uint64_t offset, std::uint64_t bytes) const {
  Mapping m;
  if (bytes == 0) return m;
  const auto page = static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
  const std::uint64_t first = offset / page * page;
  m.length_ = offset - first + bytes;
  void* const base = ::mmap(nullptr, m.length_, PROT_READ, MAP_SHARED | MAP_POPULATE, fd_, static_cast<off_t>(first));
  if (base == MAP_FAILED)
    throw io::IoError(name_ + ": cannot map " + std::to_string(bytes) + " bytes: " + std::strerror(errno));
  m.base_ = base;
  m.data_ = static_cast<const unsigned char*>(base) + (offset - first);
  m.size_ = bytes;
  return m;
}

void ScratchFile::read(void* data, std::uint64_t bytes, std::uint64_t offset) const {
  auto* p = static_cast<unsigned char*>(data);
  transfer("read", bytes, offset, [&](std::uint64_t done, std::uint64_t left, off_t at) {
    return ::pread(fd_, p + done, left, at);
  });
}

void ScratchFile::write(const void* data, std::uint64_t bytes, std::uint64_t offset) {
  const auto* p = static_cast<const unsigned char*>(data);
  transfer("write", bytes, offset, [&](std::uint64_t done, std::uint64_t left, off_t at) {
    return ::pwrite(fd_, p + done, left, at);
  });
}

void ScratchFile::transfer(const char* what, std::uint64_t bytes, std::uint64_t offset,
                           const std::function<ssize_t(std::uint64_t, std::uint64_t, off_t)>& call) const {
  std::uint64_t done = 0;
  while (done < bytes) {
    const ssize_t n = call(done, bytes - done, static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw io::IoError(name_ + ": " + what + " failed: " + std::strerror(errno));
    if (n == 0) throw io::IoError(name_ + ": " + what + " ended early");
    done += static_cast<std::uint64_t>(n);
  }
}

}  // namespace pointfair::tiles
