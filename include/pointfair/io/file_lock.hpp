#pragma once
// Exclusive ownership of a run's files: a lock held while a run works on them, and a digest
// that proves a resumed run continues the same input.
#include <cstdint>
#include <filesystem>
#include <string>

namespace pointfair::io {

/// An exclusive lock on the file `path`, held while the object lives (an open file description
/// lock, fcntl F_OFD_SETLK on byte 2^62, beyond any data, so that it never blocks the
/// byte-range locks MPI-IO takes on what it writes: it travels with the file when it is renamed, is
/// dropped by the kernel when the process ends however it ends, and is independent of the
/// flock() locks libhdf5 takes). Creates `path` (empty) when it does not exist; created()
/// then says so.
/// Throws IoError "<path>: in use by another process (a run holds its lock) ..." when another
/// process holds it, or "<path>: cannot lock: <reason>".
class FileLock {
 public:
  explicit FileLock(std::filesystem::path path);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

  const std::filesystem::path& path() const { return path_; }
  /// This lock created the file (it did not exist).
  bool created() const { return created_; }
  /// Size of the file when it was locked.
  std::uint64_t size_when_locked() const { return size_; }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  bool created_ = false;
  std::uint64_t size_ = 0;
};

/// An exclusive lock on the folder `path` (flock on the folder itself), held while the object
/// lives. Throws IoError as FileLock.
class FolderLock {
 public:
  explicit FolderLock(std::filesystem::path path);
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

/// Throws IoError "<path>: is a named pipe, not a regular file: ..." (or a device, a socket)
/// when `path` exists and is not a regular file: what the readers refuse before opening, for
/// readers that open files themselves (libhdf5). Never blocks.
void require_regular_input(const std::filesystem::path& path);

/// A 64-bit digest of bytes (not cryptographic: it tells accidental differences apart), as
/// 16 hex digits. `digest_update` continues `state` (start from kDigestSeed).
inline constexpr std::uint64_t kDigestSeed = 0x9e3779b97f4a7c15ull;
std::uint64_t digest_update(std::uint64_t state, const void* data, std::size_t size);
std::string digest_text(std::uint64_t state);

/// digest_text of the whole content of `path`, read once. Throws IoError naming the file.
std::string file_digest(const std::filesystem::path& path);

}  // namespace pointfair::io
