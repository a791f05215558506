#pragma once
// Output files that appear complete or not at all.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <optional>
#include <string_view>

namespace pointfair::io {

/// A stdio stream whose every write is checked. Does not own the stream.
class FileSink {
 public:
  /// `name` is the file named in error messages (the final target, not a temporary).
  FileSink(std::FILE* file, std::filesystem::path name);

  /// Writes `size` bytes. Throws IoError "<name>: write failed: <reason>".
  void write(const void* data, std::size_t size);
  void write(std::string_view text) { write(text.data(), text.size()); }
  /// Flushes the stdio buffer. Throws IoError "<name>: write failed: <reason>".
  void flush();
  /// Overwrites bytes already written, at `offset` from the start (e.g. a header completed at
  /// the end), then goes on appending at the end. Throws IoError as write.
  void write_at(std::uint64_t offset, std::string_view bytes);

  const std::filesystem::path& name() const { return name_; }

 private:
  std::FILE* file_;
  std::filesystem::path name_;
};

/// An output file being written under a temporary name in the target's directory
/// (".<name>.tmp-<pid>-<random>"): commit() flushes, syncs and renames it onto the target;
/// destroying it uncommitted removes the temporary and leaves an existing target untouched.
/// An existing target's permission bits are kept.
class AtomicFile {
 public:
  /// Creates the temporary. Throws IoError "<target>: <problem>" (e.g. "cannot create file:
  /// No such file or directory", "cannot write: Is a directory").
  explicit AtomicFile(std::filesystem::path target);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// Where the body goes; errors name the target.
  FileSink& sink() { return *sink_; }
  /// Flushes, syncs, closes and renames. Throws IoError "<target>: write failed: <reason>"
  /// (the temporary is removed) or "cannot replace file: <reason>".
  void commit();

 private:
  void abandon();

  std::filesystem::path target_;
  std::filesystem::path temporary_;
  std::FILE* file_ = nullptr;
  std::optional<FileSink> sink_;
};

/// Writes `target` by calling `write_body` on a new temporary file in the same directory
/// (".<name>.tmp-<pid>-<random>"), then flushing, syncing and renaming it onto `target`.
/// A reader of `target` sees the old file or the complete new one, never a partial one.
/// On any failure, including an exception from `write_body`, the temporary file is removed,
/// an existing `target` is left untouched and the exception propagates. An existing target's
/// permission bits are kept.
/// Throws IoError "<target>: <problem>" (e.g. "write failed: No space left on device",
/// "cannot create file: No such file or directory").
void write_file_atomically(const std::filesystem::path& target,
                           const std::function<void(FileSink&)>& write_body);

/// Throws IoError "<output>: exists and is not a regular file (a named pipe): refused" when
/// `output` (followed through symlinks) exists and is a named pipe, a device, a socket, or
/// "cannot write: Is a directory" for a folder: an output is only ever written by replacing a
/// regular file (or making a new one), never by writing into or replacing anything else.
void require_output_path(const std::filesystem::path& output);

/// Throws IoError "<output>: output would overwrite the input" if `output` names the same
/// file as `input`: the same file on disk when `output` exists, else the same normalised
/// absolute path.
void require_distinct(const std::filesystem::path& input, const std::filesystem::path& output);

}  // namespace pointfair::io
