#pragma once
// Internal buffered reader for point files: lines for headers and text bodies, raw bytes
// for binary bodies, and the number of bytes left so that counts in a header can be
// checked against the file size before anything is allocated.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace pointfair::io::detail {

/// "a named pipe", "a character device", ... for a stat mode that is not a regular file's.
std::string non_regular_kind(unsigned mode);

/// Throws IoError "<path>: is a named pipe, not a regular file: ..." when `path` exists and is
/// not a regular file (folders: "cannot open: Is a directory"). Does not open it.
void require_regular_input(const std::filesystem::path& path);

class FileReader {
 public:
  /// Opens `path` for reading. Throws IoError "<path>: cannot open: <reason>".
  explicit FileReader(std::filesystem::path path);
  ~FileReader();
  FileReader(const FileReader&) = delete;
  FileReader& operator=(const FileReader&) = delete;

  const std::filesystem::path& path() const { return path_; }
  /// Size of the file when it was opened. A file found shorter than this while reading
  /// (it shrank) is an IoError "file shrank while being read"; bytes appended after the
  /// open are read like any others (the formats' readers decide what to do with them).
  std::uint64_t size() const { return size_; }
  /// Bytes not yet returned by next_line/read/skip.
  std::uint64_t remaining() const { return consumed_ < size_ ? size_ - consumed_ : 0; }
  /// 1-based number of the line last returned by next_line.
  std::uint64_t line_number() const { return line_number_; }

  /// The next line without its '\n' (and without a trailing '\r'); false at end of file.
  /// The view stays valid until the next call on this reader. Throws IoError on read errors.
  bool next_line(std::string_view& line);
  /// The line last returned by next_line ended with "\r\n" (or a lone final '\r').
  bool line_had_cr() const { return line_had_cr_; }
  /// Copies up to `size` bytes into `out`; returns how many were available.
  std::size_t read(char* out, std::size_t size);
  /// Skips up to `size` bytes; returns how many were skipped.
  std::uint64_t skip(std::uint64_t size);

 private:
  /// Moves unread bytes to the front and reads more; false when nothing more was read.
  bool refill();
  std::size_t read_from_file(char* out, std::size_t size);

  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  std::uint64_t size_ = 0;
  std::uint64_t consumed_ = 0;
  std::uint64_t line_number_ = 0;
  bool line_had_cr_ = false;
  std::uint64_t read_total_ = 0;  // bytes read from the file so far
  std::vector<char> buffer_;
  std::size_t begin_ = 0;  // first unread byte in buffer_
  std::size_t end_ = 0;    // one past the last valid byte in buffer_
};

}  // namespace pointfair::io::detail
