#pragma once
// A thin RAII wrapper over the HDF5 C API: the one place of the project that calls it.
// Handles close themselves; every failure throws io::IoError "<file>: <object>: <problem>".
//
// Thread-safety: libhdf5 (serial build) is not thread-safe; keep every call on one thread.
// Processes: builds with -DPOINTFAIR_MPI=ON link parallel HDF5, and File::open_parallel opens
// one file on every rank of an MPI job; its reads and writes are independent or collective
// (Transfer). The serial libhdf5 has no MPI-IO: there every transfer is independent.
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "pointfair/io/point_table.hpp"

namespace pointfair::tiles::h5 {

using hid = std::int64_t;  // hid_t of HDF5 1.10+, kept out of the public headers

/// Element types of datasets and attributes (the file stores them little endian).
enum class Type { Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64 };

template <class T>
constexpr Type type_of() {
  if constexpr (std::is_same_v<T, std::int8_t>) return Type::Int8;
  else if constexpr (std::is_same_v<T, std::uint8_t>) return Type::UInt8;
  else if constexpr (std::is_same_v<T, std::int16_t>) return Type::Int16;
  else if constexpr (std::is_same_v<T, std::uint16_t>) return Type::UInt16;
  else if constexpr (std::is_same_v<T, std::int32_t>) return Type::Int32;
  else if constexpr (std::is_same_v<T, std::uint32_t>) return Type::UInt32;
  else if constexpr (std::is_same_v<T, std::int64_t>) return Type::Int64;
  else if constexpr (std::is_same_v<T, std::uint64_t>) return Type::UInt64;
  else if constexpr (std::is_same_v<T, float>) return Type::Float32;
  else {
    static_assert(std::is_same_v<T, double>, "unsupported HDF5 element type");
    return Type::Float64;
  }
}

/// Maps a point-table scalar type to the HDF5 element type and back.
Type to_h5(io::ScalarType type);
io::ScalarType to_scalar(Type type);

/// An owned HDF5 identifier (closed with the function matching its kind).
class Handle {
 public:
  Handle() = default;
  explicit Handle(hid id) : id_(id) {}
  ~Handle();
  Handle(Handle&& other) noexcept : id_(other.id_) { other.id_ = -1; }
  Handle& operator=(Handle&& other) noexcept;
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid get() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid id_ = -1;
};

struct DatasetOptions {
  /// Rows per chunk (0: contiguous layout). Matched to tile reads by the callers.
  std::uint64_t chunk_rows = 0;
  /// Deflate level 1..9 with the shuffle filter; 0: no compression (needs chunk_rows > 0).
  int deflate = 0;
  /// Allocate all storage at creation, so later writes change no file metadata (resumable
  /// runs rely on this: a kill during a step cannot damage the file's structure).
  bool allocate_early = false;
};

/// How a dataset transfer on a file opened by every rank (File::open_parallel) is made:
/// Independent, by this process alone; Collective (MPI-IO collective, H5FD_MPIO_COLLECTIVE),
/// together with every rank of the communicator, which must all make the same collective
/// calls on the same datasets in the same order (a rank with nothing to move takes part with
/// count 0 or no rows: an empty selection). Lets the MPI-IO layer merge the ranks' requests
/// into few large file accesses. A file opened by one process transfers independently
/// whatever is asked.
enum class Transfer { Independent, Collective };

/// Collective transfers made by this process so far, and those libhdf5 carried out
/// independently instead (with the reason bits of the last one, H5D_mpio_no_collective_cause_t).
/// Process-wide; HDF5 calls stay on one thread.
struct TransferCounts {
  std::uint64_t collective = 0;
  std::uint64_t fell_back = 0;
  std::uint32_t last_cause = 0;
};
TransferCounts transfer_counts();

class File;

/// A dataset of `rows` rows of `width` elements each (shape [rows] when width is 1 and the
/// dataset was created one-dimensional, else [rows, width]).
class Dataset {
 public:
  std::uint64_t rows() const { return rows_; }
  std::uint64_t width() const { return width_; }
  Type type() const { return type_; }
  const std::string& path() const { return path_; }
  /// Bytes the file holds for this dataset (H5Dget_storage_size: allocated chunks or extent),
  /// and bytes of one element in the file. A shape can claim far more than is stored.
  std::uint64_t stored_bytes() const;
  std::uint64_t element_bytes() const;

  /// Rows [first, first + count) into `out` (count * width elements), converted to T.
  /// Collective transfers with count 0 take part with an empty selection (`out` unused).
  template <class T>
  void read_rows(std::uint64_t first, std::uint64_t count, T* out, Transfer transfer = Transfer::Independent) const {
    read_rows_raw(first, count, type_of<T>(), out, transfer);
  }
  template <class T>
  void write_rows(std::uint64_t first, std::uint64_t count, const T* data,
                  Transfer transfer = Transfer::Independent) {
    write_rows_raw(first, count, type_of<T>(), data, transfer);
  }
  /// The rows listed in `rows` (strictly increasing) into `out`, row after row.
  template <class T>
  void read_selected(std::span<const std::uint64_t> rows, T* out, Transfer transfer = Transfer::Independent) const {
    read_selected_raw(rows, type_of<T>(), out, transfer);
  }
  template <class T>
  std::vector<T> read_all() const {
    std::vector<T> v(static_cast<std::size_t>(rows_ * width_));
    if (!v.empty()) read_rows(0, rows_, v.data());
    return v;
  }

 private:
  friend class File;
  Dataset(const File* file, std::string path, Handle handle);
  void read_rows_raw(std::uint64_t first, std::uint64_t count, Type memory, void* out, Transfer transfer) const;
  void write_rows_raw(std::uint64_t first, std::uint64_t count, Type memory, const void* data, Transfer transfer);
  void read_selected_raw(std::span<const std::uint64_t> rows, Type memory, void* out, Transfer transfer) const;
  // One H5Dread of the rows through a hyperslab union or a point selection.
  void read_selection(std::span<const std::uint64_t> rows, Type memory, void* out, bool collective) const;
  bool together(Transfer transfer) const;
  [[noreturn]] void fail(std::string_view problem) const;

  const File* file_;
  std::string path_;
  Handle handle_;
  std::uint64_t rows_ = 0, width_ = 1;
  int rank_ = 1;
  Type type_ = Type::Float64;
};

/// An open HDF5 file. Object paths are absolute ("/points/positions").
class File {
 public:
  /// Creates (truncating) `path`. Throws IoError "<path>: cannot create HDF5 file".
  static File create(const std::filesystem::path& path);
  /// Opens an existing file. Throws IoError "<path>: not an HDF5 file" or "cannot open ...".
  static File open(const std::filesystem::path& path, bool writable);
  /// Opens an existing file for reading and writing on every process of an MPI communicator,
  /// through the MPI-IO driver: a collective call (so are flush() and closing). `mpi_comm`
  /// points to the MPI_Comm. Dataset transfers are independent unless asked to be
  /// collective (Transfer). Only in builds against parallel HDF5 (parallel_available());
  /// elsewhere throws IoError.
  static File open_parallel(const std::filesystem::path& path, const void* mpi_comm);
  /// Creates (truncating) `path` on every process of an MPI communicator, as open_parallel.
  static File create_parallel(const std::filesystem::path& path, const void* mpi_comm);
  static bool parallel_available();

  const std::filesystem::path& name() const { return name_; }
  /// Opened by every rank of a communicator (open_parallel).
  bool parallel() const { return parallel_; }
  hid id() const { return handle_.get(); }

  /// Writes every cached change to the file (H5Fflush) and syncs it to disk. Throws IoError
  /// "<file>: write failed: <reason>" where the sync fails (e.g. an I/O error).
  void flush();
  /// Asks the kernel to start writing the file's dirty pages to disk, without waiting for
  /// them (sync_file_range): a later flush() then waits only for what is still in flight.
  /// What HDF5 keeps in its own caches is not touched. Nothing for a parallel file.
  void start_writeback() const;
  /// Closes the file; later use is an error. Called by the destructor.
  void close();

  bool exists(std::string_view path) const;
  /// Creates a group whose members keep their creation order.
  void create_group(std::string_view path);
  /// Names of the members of a group, in creation order when tracked, else by name.
  std::vector<std::string> members(std::string_view group) const;

  /// Creates a dataset [rows] (width 0) or [rows, width].
  Dataset create_dataset(std::string_view path, Type type, std::uint64_t rows,
                         std::uint64_t width, const DatasetOptions& options = {});
  Dataset dataset(std::string_view path) const;
  /// Copies an object (group or dataset, with everything below it) from another file.
  void copy_from(const File& source, std::string_view source_path, std::string_view path);

  /// Attributes on an object ("/" for the file).
  void set_attribute(std::string_view object, std::string_view name, std::string_view value);
  void set_attribute(std::string_view object, std::string_view name, double value);
  void set_attribute(std::string_view object, std::string_view name, std::int64_t value);
  void set_attribute(std::string_view object, std::string_view name, std::span<const double> values);
  bool has_attribute(std::string_view object, std::string_view name) const;
  std::string string_attribute(std::string_view object, std::string_view name) const;
  double double_attribute(std::string_view object, std::string_view name) const;
  std::int64_t int_attribute(std::string_view object, std::string_view name) const;
  std::vector<double> doubles_attribute(std::string_view object, std::string_view name) const;

  [[noreturn]] void fail(std::string_view object, std::string_view problem) const;

 private:
  File(std::filesystem::path name, Handle handle) : name_(std::move(name)), handle_(std::move(handle)) {}
  Handle open_object(std::string_view object) const;
  /// The descriptor libhdf5's POSIX driver writes the file through (asked once); -1 for a
  /// parallel file or another driver.
  int descriptor() const;

  std::filesystem::path name_;
  Handle handle_;
  bool parallel_ = false;
  mutable int descriptor_ = kNotAsked;
  static constexpr int kNotAsked = -2;
};

}  // namespace pointfair::tiles::h5
