#pragma once
// Point files read and written a chunk of points at a time, so that a cloud larger than
// memory can stream through (import into a container, export from one). The in-memory
// readers and writers (read_ply, write_xyz, ...) are one chunk of everything.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>

#include "pointfair/io/point_table.hpp"

namespace pointfair::io {

/// Reads the points of one file in order, up to a given number at a time. The schema (the
/// attribute names and types, the position type) is known once the reader is open. Errors
/// are those of the format's in-memory reader, thrown by the call that meets them; warnings
/// about what follows the points (ignored elements, trailing data) are given when the last
/// point has been read. Not thread-safe.
class PointChunkReader {
 public:
  virtual ~PointChunkReader() = default;

  const std::filesystem::path& path() const { return path_; }
  /// A table with no points: the attributes (name, type, empty values) and position_type
  /// every chunk has.
  const PointTable& schema() const { return schema_; }
  /// The number of points when the format declares it up front (PLY); nullopt for text.
  virtual std::optional<std::uint64_t> count() const = 0;
  /// Points returned so far.
  std::uint64_t points_read() const { return points_read_; }

  /// Replaces the contents of `chunk` with the next `max_points` points (fewer at the end of
  /// the file), keeping the schema; returns how many. 0 means the end (and stays 0).
  /// `max_points` must be >= 1. The chunk's vectors keep their capacity between calls.
  std::size_t read(PointTable& chunk, std::size_t max_points);
  /// Passes over the next `points` points (at most those left) without returning them;
  /// returns how many. Binary formats of fixed-size records (binary PLY, LAS) seek over all
  /// but the last of them and read that one; the others read and drop them all. Lets the
  /// processes of a job each read their own share of one file. Skipping to the end handles
  /// what follows the points (warnings, a LAS file's EVLRs) as reading to the end does.
  std::uint64_t skip(std::uint64_t points);

 protected:
  explicit PointChunkReader(std::filesystem::path path) : path_(std::move(path)) {}
  /// Appends up to `max_points` points to `chunk` (whose columns match the schema).
  virtual std::size_t append(PointTable& chunk, std::size_t max_points) = 0;
  /// Seeks over `points` points (no more than are left); false when the format cannot (then
  /// skip() reads through them).
  virtual bool seek_over(std::uint64_t /*points*/) { return false; }

  std::filesystem::path path_;
  PointTable schema_;
  std::uint64_t points_read_ = 0;
};

/// Writes the points of one file a chunk at a time, atomically: the file appears under its
/// name only when finish() succeeds; a writer destroyed before (an exception on the way)
/// removes its temporary file and leaves an existing file of that name untouched.
class PointChunkWriter {
 public:
  virtual ~PointChunkWriter() = default;

  /// Appends the points of `chunk`, whose attributes must match the schema given when the
  /// writer was opened (names, types and order). Throws IoError "<file>: <problem>" for a
  /// mismatch, a non-finite position, more points than declared or a write failure.
  virtual void write(const PointTable& chunk) = 0;
  /// Completes the file and renames it into place. Throws IoError when fewer points than
  /// declared were written, or on a write failure.
  virtual void finish() = 0;
  /// Points written so far.
  std::uint64_t points_written() const { return points_written_; }

 protected:
  std::uint64_t points_written_ = 0;
};

}  // namespace pointfair::io
