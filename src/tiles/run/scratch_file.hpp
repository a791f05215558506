#pragma once
// A scratch file of a run: unlinked as soon as it is open, so that it leaves nothing behind
// when the run ends or is killed, read and written at offsets (no HDF5). What a run keeps in
// one is never needed to resume it. Internal: not installed.
#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

namespace pointfair::tiles {

class ScratchFile {
 public:
  /// A new file in `directory`; `name` is what errors call it. Throws io::IoError
  /// "<name>: cannot create: <reason>".
  ScratchFile(const std::filesystem::path& directory, std::string name);
  ~ScratchFile();
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  /// Room for `bytes` now, so that a full disk shows here rather than later. Throws io::IoError.
  void reserve(std::uint64_t bytes);
  /// Bytes at `offset` into `data`, or from it. Throw io::IoError naming the file and the reason.
  void read(void* data, std::uint64_t bytes, std::uint64_t offset) const;
  void write(const void* data, std::uint64_t bytes, std::uint64_t offset);
  const std::string& name() const { return name_; }

  /// Bytes of the file mapped read-only into memory, its pages loaded at once (the kernel's
  /// page cache, not a copy): unmapped when the Mapping goes. Valid after the ScratchFile is
  /// gone. Its data is aligned as `offset` is to 4096.
  class Mapping {
   public:
    Mapping() = default;
    ~Mapping();
    Mapping(Mapping&& other) noexcept;
    Mapping& operator=(Mapping&& other) noexcept;
    Mapping(const Mapping&) = delete;
    Mapping& operator=(const Mapping&) = delete;
    const unsigned char* data() const { return data_; }
    std::uint64_t size() const { return size_; }

   private:
    friend class ScratchFile;
    void* base_ = nullptr;
    std::uint64_t length_ = 0;
    const unsigned char* data_ = nullptr;
    std::uint64_t size_ = 0;
  };
  /// Throws io::IoError "<name>: cannot map ...: <reason>".
  Mapping map(std::uint64_t offset, std::uint64_t bytes) const;

 private:
  // Calls `call(done, left, at)` (a pread or pwrite of the `left` bytes after the first `done`,
  // at file offset `at`) until `bytes` are moved; `what` names the transfer in errors.
  void transfer(const char* what, std::uint64_t bytes, std::uint64_t offset,
                const std::function<ssize_t(std::uint64_t, std::uint64_t, off_t)>& call) const;
  std::string name_;
  int fd_ = -1;
};

}  // namespace pointfair::tiles
