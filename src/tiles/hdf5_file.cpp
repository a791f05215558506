// The HDF5 C API, wrapped: handles, datasets by rows, attributes, errors as io::IoError.
#include "pointfair/tiles/hdf5_file.hpp"
#include "pointfair/io/file_lock.hpp"

#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <mutex>

#include <hdf5.h>

namespace pointfair::tiles::h5 {
namespace {

static_assert(std::is_same_v<hid, hid_t>, "hid_t is 64 bits since HDF5 1.10");

// libhdf5 prints its error stack to stderr by default; our errors are one line each.
// Its exit-time cleanup is turned off: every handle here closes itself, and after a failed
// write (a full disk) a dataset whose close failed stays registered, and closing it again
// at exit crashed inside libhdf5 (H5D_close, after the error had been reported).
void quiet_hdf5() {
  static std::once_flag once;
  std::call_once(once, [] {
    H5dont_atexit();  // fails harmlessly if the library was already in use
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  });
}

// The operating system's words for the innermost error of libhdf5's current error stack
// (e.g. "No space left on device", "File too large"), from the "error message = '...'" part
// its low-level file drivers write; empty when the failure did not come from the system.
std::string hdf5_error_reason() {
  std::string innermost;
  const auto visit = [](unsigned depth, const H5E_error2_t* error, void* data) -> herr_t {
    auto& text = *static_cast<std::string*>(data);
    if (depth == 0 && error->desc != nullptr) text = error->desc;
    return 0;
  };
  if (H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, visit, &innermost) < 0) return {};
  const std::string key = "error message = '";
  const std::size_t begin = innermost.find(key);
  if (begin == std::string::npos) return {};
  const std::size_t end = innermost.find('\'', begin + key.size());
  if (end == std::string::npos) return {};
  return innermost.substr(begin + key.size(), end - begin - key.size());
}

hid_t memory_type(Type t) {
  switch (t) {
    case Type::Int8: return H5T_NATIVE_INT8;
    case Type::UInt8: return H5T_NATIVE_UINT8;
    case Type::Int16: return H5T_NATIVE_INT16;
    case Type::UInt16: return H5T_NATIVE_UINT16;
    case Type::Int32: return H5T_NATIVE_INT32;
    case Type::UInt32: return H5T_NATIVE_UINT32;
    case Type::Int64: return H5T_NATIVE_INT64;
    case Type::UInt64: return H5T_NATIVE_UINT64;
    case Type::Float32: return H5T_NATIVE_FLOAT;
    case Type::Float64: return H5T_NATIVE_DOUBLE;
  }
  return H5T_NATIVE_DOUBLE;
}

hid_t file_type(Type t) {
  switch (t) {
    case Type::Int8: return H5T_STD_I8LE;
    case Type::UInt8: return H5T_STD_U8LE;
    case Type::Int16: return H5T_STD_I16LE;
    case Type::UInt16: return H5T_STD_U16LE;
    case Type::Int32: return H5T_STD_I32LE;
    case Type::UInt32: return H5T_STD_U32LE;
    case Type::Int64: return H5T_STD_I64LE;
    case Type::UInt64: return H5T_STD_U64LE;
    case Type::Float32: return H5T_IEEE_F32LE;
    case Type::Float64: return H5T_IEEE_F64LE;
  }
  return H5T_IEEE_F64LE;
}

// The element type of a stored dataset, or nullopt-like false if it is not one of ours.
bool classify(hid_t type, Type& out) {
  const H5T_class_t cls = H5Tget_class(type);
  const std::size_t size = H5Tget_size(type);
  if (cls == H5T_FLOAT) {
    if (size == 4) { out = Type::Float32; return true; }
    if (size == 8) { out = Type::Float64; return true; }
    return false;
  }
  if (cls != H5T_INTEGER) return false;
  const bool is_signed = H5Tget_sign(type) == H5T_SGN_2;
  switch (size) {
    case 1: out = is_signed ? Type::Int8 : Type::UInt8; return true;
    case 2: out = is_signed ? Type::Int16 : Type::UInt16; return true;
    case 4: out = is_signed ? Type::Int32 : Type::UInt32; return true;
    case 8: out = is_signed ? Type::Int64 : Type::UInt64; return true;
    default: return false;
  }
}

std::string object_or_root(std::string_view object) {
  return object.empty() ? std::string("/") : std::string(object);
}

TransferCounts counts_;

// The data transfer property list of a transfer: MPI-IO collective, or none (H5P_DEFAULT).
Handle transfer_list(bool collective) {
#ifdef H5_HAVE_PARALLEL
  if (collective) {
    Handle dxpl(H5Pcreate(H5P_DATASET_XFER));
    H5Pset_dxpl_mpio(dxpl.get(), H5FD_MPIO_COLLECTIVE);
    return dxpl;
  }
#else
  (void)collective;
#endif
  return Handle();
}

hid_t list_or_default(const Handle& dxpl) { return dxpl.valid() ? dxpl.get() : H5P_DEFAULT; }

// Counts a collective transfer, and whether libhdf5 had to make it independently after all.
void count_transfer(const Handle& dxpl) {
#ifdef H5_HAVE_PARALLEL
  if (!dxpl.valid()) return;
  std::uint32_t local = 0, global = 0;
  if (H5Pget_mpio_no_collective_cause(dxpl.get(), &local, &global) < 0) return;
  if (global == H5D_MPIO_COLLECTIVE) {
    ++counts_.collective;
  } else {
    ++counts_.fell_back;
    counts_.last_cause = global;
  }
#else
  (void)dxpl;
#endif
}

// A memory space of no elements for a collective transfer a rank takes part in with nothing.
Handle empty_space(int rank, hsize_t width) {
  const hsize_t dims[2] = {1, width};
  Handle space(H5Screate_simple(rank, dims, nullptr));
  H5Sselect_none(space.get());
  return space;
}

// File and memory selections of rows [first, first + count) of `dataset` (rank 1 or 2, `width`
// columns); count 0 selects nothing, for a collective transfer with no rows of its own.
struct RowSelection {
  Handle file_space;
  Handle mem_space;
};
RowSelection select_rows(hid_t dataset, int rank, hsize_t width, std::uint64_t first, std::uint64_t count) {
  RowSelection s{Handle(H5Dget_space(dataset)), Handle()};
  if (count == 0) {
    H5Sselect_none(s.file_space.get());
    s.mem_space = empty_space(rank, width);
  } else {
    const hsize_t start[2] = {first, 0}, extent[2] = {count, width};
    H5Sselect_hyperslab(s.file_space.get(), H5S_SELECT_SET, start, nullptr, extent, nullptr);
    s.mem_space = Handle(H5Screate_simple(rank, extent, nullptr));
  }
  return s;
}

}  // namespace

TransferCounts transfer_counts() { return counts_; }

Type to_h5(io::ScalarType t) {
  switch (t) {
    case io::ScalarType::Int8: return Type::Int8;
    case io::ScalarType::UInt8: return Type::UInt8;
    case io::ScalarType::Int16: return Type::Int16;
    case io::ScalarType::UInt16: return Type::UInt16;
    case io::ScalarType::Int32: return Type::Int32;
    case io::ScalarType::UInt32: return Type::UInt32;
    case io::ScalarType::Float32: return Type::Float32;
    case io::ScalarType::Float64: return Type::Float64;
  }
  return Type::Float64;
}

io::ScalarType to_scalar(Type t) {
  switch (t) {
    case Type::Int8: return io::ScalarType::Int8;
    case Type::UInt8: return io::ScalarType::UInt8;
    case Type::Int16: return io::ScalarType::Int16;
    case Type::UInt16: return io::ScalarType::UInt16;
    case Type::Int32: return io::ScalarType::Int32;
    case Type::UInt32: return io::ScalarType::UInt32;
    case Type::Float32: return io::ScalarType::Float32;
    case Type::Int64: case Type::UInt64: case Type::Float64: return io::ScalarType::Float64;
  }
  return io::ScalarType::Float64;
}

Handle::~Handle() {
  if (id_ >= 0) H5Idec_ref(id_);
}

Handle& Handle::operator=(Handle&& other) noexcept {
  if (this != &other) {
    if (id_ >= 0) H5Idec_ref(id_);
    id_ = other.id_;
    other.id_ = -1;
  }
  return *this;
}

// ---- File -----------------------------------------------------------------------------------

void File::fail(std::string_view object, std::string_view problem) const {
  std::string message = name_.string();
  if (!object.empty()) message += std::string(": ") + std::string(object);
  message += std::string(": ") + std::string(problem);
  const std::string reason = hdf5_error_reason();
  if (!reason.empty()) message += " (" + reason + ")";
  throw io::IoError(message);
}

File File::create(const std::filesystem::path& path) {
  quiet_hdf5();
  Handle h(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  if (!h.valid()) {
    throw io::IoError(path.string() + ": cannot create HDF5 file" +
                      (errno != 0 ? std::string(": ") + std::strerror(errno) : std::string()));
  }
  return File(path, std::move(h));
}

File File::open(const std::filesystem::path& path, bool writable) {
  quiet_hdf5();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw io::IoError(path.string() + ": cannot open: No such file or directory");
  io::require_regular_input(path);  // libhdf5 would block on a named pipe
  if (H5Fis_hdf5(path.c_str()) <= 0) throw io::IoError(path.string() + ": not an HDF5 file");
  Handle h(H5Fopen(path.c_str(), writable ? H5F_ACC_RDWR : H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!h.valid()) throw io::IoError(path.string() + ": cannot open HDF5 file (damaged or locked)");
  return File(path, std::move(h));
}

bool File::parallel_available() {
#ifdef H5_HAVE_PARALLEL
  return true;
#else
  return false;
#endif
}

File File::open_parallel(const std::filesystem::path& path, const void* mpi_comm) {
  quiet_hdf5();
#ifdef H5_HAVE_PARALLEL
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw io::IoError(path.string() + ": cannot open: No such file or directory");
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS));
  if (H5Pset_fapl_mpio(fapl.get(), *static_cast<const MPI_Comm*>(mpi_comm), MPI_INFO_NULL) < 0)
    throw io::IoError(path.string() + ": cannot set up the MPI-IO driver");
  Handle h(H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl.get()));
  if (!h.valid()) throw io::IoError(path.string() + ": cannot open HDF5 file on every rank (damaged or locked)");
  File f(path, std::move(h));
  f.parallel_ = true;
  return f;
#else
  (void)mpi_comm;
  throw io::IoError(path.string() + ": this build has no parallel HDF5 (configure with -DPOINTFAIR_MPI=ON)");
#endif
}

File File::create_parallel(const std::filesystem::path& path, const void* mpi_comm) {
  quiet_hdf5();
#ifdef H5_HAVE_PARALLEL
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS));
  if (H5Pset_fapl_mpio(fapl.get(), *static_cast<const MPI_Comm*>(mpi_comm), MPI_INFO_NULL) < 0)
    throw io::IoError(path.string() + ": cannot set up the MPI-IO driver");
  Handle h(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()));
  if (!h.valid()) throw io::IoError(path.string() + ": cannot create HDF5 file on every rank");
  File f(path, std::move(h));
  f.parallel_ = true;
  return f;
#else
  (void)mpi_comm;
  throw io::IoError(path.string() + ": this build has no parallel HDF5 (configure with -DPOINTFAIR_MPI=ON)");
#endif
}

void File::flush() {
  if (H5Fflush(handle_.get(), H5F_SCOPE_GLOBAL) < 0) fail("", "flush failed");
  // H5Fflush hands the data to the kernel; make it durable as well. A failed sync (EIO, or
  // ENOSPC where the file system allocates at writeback) means that what was written may never
  // reach the disk: an error, so that nothing after it (a step's commit) counts on it. EINVAL:
  // the file system cannot sync this kind of file, which loses nothing.
  const int opened = parallel_ ? ::open(name_.c_str(), O_RDONLY | O_CLOEXEC) : -1;
  const int fd = parallel_ ? opened : descriptor();
  if (fd < 0) return;
  const int synced = ::fsync(fd);
  const int error = errno;
  if (opened >= 0) ::close(opened);
  if (synced != 0 && error != EINVAL) fail("", std::string("write failed: ") + std::strerror(error));
}

void File::start_writeback() const {
  const int fd = descriptor();
  if (fd >= 0) ::sync_file_range(fd, 0, 0, SYNC_FILE_RANGE_WRITE);
}

int File::descriptor() const {
  if (descriptor_ != kNotAsked) return descriptor_;
  descriptor_ = -1;
  if (parallel_ || !handle_.valid()) return descriptor_;
  Handle access(H5Fget_access_plist(handle_.get()));
  if (!access.valid() || H5Pget_driver(access.get()) != H5FD_SEC2) return descriptor_;
  void* vfd = nullptr;
  if (H5Fget_vfd_handle(handle_.get(), access.get(), &vfd) >= 0 && vfd != nullptr)
    descriptor_ = *static_cast<int*>(vfd);
  return descriptor_;
}

void File::close() {
  handle_ = Handle();
  descriptor_ = kNotAsked;
}

bool File::exists(std::string_view path) const {
  if (path == "/" || path.empty()) return true;
  // H5Lexists needs every parent to exist: walk the path.
  std::size_t pos = 1;
  while (pos <= path.size()) {
    const std::size_t next = std::min(path.find('/', pos), path.size());
    const std::string prefix(path.substr(0, next));
    if (H5Lexists(handle_.get(), prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    pos = next + 1;
  }
  return true;
}

void File::create_group(std::string_view path) {
  Handle gcpl(H5Pcreate(H5P_GROUP_CREATE));
  H5Pset_link_creation_order(gcpl.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
  const std::string p(path);
  Handle g(H5Gcreate2(handle_.get(), p.c_str(), H5P_DEFAULT, gcpl.get(), H5P_DEFAULT));
  if (!g.valid()) fail(path, "cannot create group");
}

std::vector<std::string> File::members(std::string_view group) const {
  const std::string p = object_or_root(group);
  Handle g(H5Gopen2(handle_.get(), p.c_str(), H5P_DEFAULT));
  if (!g.valid()) fail(group, "no such group");
  H5G_info_t info;
  if (H5Gget_info(g.get(), &info) < 0) fail(group, "cannot read group");
  unsigned flags = 0;
  Handle gcpl(H5Gget_create_plist(g.get()));
  H5Pget_link_creation_order(gcpl.get(), &flags);
  const H5_index_t index = (flags & H5P_CRT_ORDER_INDEXED) ? H5_INDEX_CRT_ORDER : H5_INDEX_NAME;
  std::vector<std::string> names;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    const ssize_t len = H5Lget_name_by_idx(g.get(), ".", index, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
    if (len < 0) fail(group, "cannot list members");
    std::string name(static_cast<std::size_t>(len), '\0');
    H5Lget_name_by_idx(g.get(), ".", index, H5_ITER_INC, i, name.data(), name.size() + 1, H5P_DEFAULT);
    names.push_back(std::move(name));
  }
  return names;
}

Dataset File::create_dataset(std::string_view path, Type type, std::uint64_t rows,
                             std::uint64_t width, const DatasetOptions& options) {
  const int rank = width == 0 ? 1 : 2;
  const hsize_t dims[2] = {rows, width == 0 ? 1 : width};
  Handle space(H5Screate_simple(rank, dims, nullptr));
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE));
  H5Pset_obj_track_times(dcpl.get(), false);  // identical runs give identical files
  if (options.chunk_rows > 0 && rows > 0) {
    const hsize_t chunk[2] = {std::min<hsize_t>(options.chunk_rows, rows), dims[1]};
    H5Pset_chunk(dcpl.get(), rank, chunk);
    if (options.deflate > 0) {
      H5Pset_shuffle(dcpl.get());
      H5Pset_deflate(dcpl.get(), static_cast<unsigned>(options.deflate));
    }
  }
  if (options.allocate_early) {
    H5Pset_alloc_time(dcpl.get(), H5D_ALLOC_TIME_EARLY);
    H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_NEVER);
  }
  const std::string p(path);
  Handle d(H5Dcreate2(handle_.get(), p.c_str(), file_type(type), space.get(), H5P_DEFAULT,
                      dcpl.get(), H5P_DEFAULT));
  if (!d.valid()) fail(path, "cannot create dataset");
  return Dataset(this, p, std::move(d));
}

Dataset File::dataset(std::string_view path) const {
  if (!exists(path)) fail(path, "missing dataset");
  const std::string p(path);
  Handle d(H5Dopen2(handle_.get(), p.c_str(), H5P_DEFAULT));
  if (!d.valid()) fail(path, "cannot open dataset");
  return Dataset(this, p, std::move(d));
}

void File::copy_from(const File& source, std::string_view source_path, std::string_view path) {
  const std::string s(source_path), d(path);
  // libhdf5 1.10 crashes (SIGSEGV in H5T_close_real) cleaning up after a write that fails
  // inside H5Ocopy. What is copied is at most the source file's size: a file-size limit
  // (ulimit -f) or a disk without that room fails here instead, with the system's reason.
  std::error_code ec;
  const auto needed = std::filesystem::file_size(source.name(), ec);
  struct stat here {};
  const int fd = parallel_ ? -1 : descriptor();
  if (!ec && fd >= 0 && ::fstat(fd, &here) == 0) {
    const auto after = static_cast<std::uint64_t>(here.st_size) + needed;
    rlimit limit{};
    if (::getrlimit(RLIMIT_FSIZE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY && after > limit.rlim_cur)
      fail(path, "write failed: " + std::string(std::strerror(EFBIG)) + " (copying " + s + " from " +
                     source.name().string() + " needs " + std::to_string(needed) +
                     " bytes, beyond the file-size limit of " + std::to_string(limit.rlim_cur) + " bytes)");
    struct statvfs disk {};
    if (::fstatvfs(fd, &disk) == 0 && static_cast<std::uint64_t>(disk.f_bavail) * disk.f_frsize < needed)
      fail(path, "write failed: " + std::string(std::strerror(ENOSPC)) + " (copying " + s + " from " +
                     source.name().string() + " needs " + std::to_string(needed) + " bytes)");
  }
  if (H5Ocopy(source.id(), s.c_str(), handle_.get(), d.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0)
    fail(path, "cannot copy " + s + " from " + source.name().string());
}

Handle File::open_object(std::string_view object) const {
  const std::string p = object_or_root(object);
  Handle o(H5Oopen(handle_.get(), p.c_str(), H5P_DEFAULT));
  if (!o.valid()) fail(object, "no such object");
  return o;
}

namespace {

void write_attribute(const File& f, hid_t obj, std::string_view object, std::string_view name,
                     hid_t file_t, hid_t mem_t, hid_t space, const void* data) {
  const std::string n(name);
  if (H5Aexists(obj, n.c_str()) > 0) H5Adelete(obj, n.c_str());
  Handle a(H5Acreate2(obj, n.c_str(), file_t, space, H5P_DEFAULT, H5P_DEFAULT));
  if (!a.valid() || H5Awrite(a.get(), mem_t, data) < 0)
    f.fail(object, "cannot write attribute " + n);
}

}  // namespace

void File::set_attribute(std::string_view object, std::string_view name, std::string_view value) {
  Handle obj = open_object(object);
  Handle type(H5Tcopy(H5T_C_S1));
  H5Tset_size(type.get(), std::max<std::size_t>(1, value.size()));
  H5Tset_strpad(type.get(), H5T_STR_NULLPAD);
  Handle space(H5Screate(H5S_SCALAR));
  std::string padded(value);
  if (padded.empty()) padded.push_back('\0');
  write_attribute(*this, obj.get(), object, name, type.get(), type.get(), space.get(), padded.data());
}

void File::set_attribute(std::string_view object, std::string_view name, double value) {
  Handle obj = open_object(object);
  Handle space(H5Screate(H5S_SCALAR));
  write_attribute(*this, obj.get(), object, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, space.get(), &value);
}

void File::set_attribute(std::string_view object, std::string_view name, std::int64_t value) {
  Handle obj = open_object(object);
  Handle space(H5Screate(H5S_SCALAR));
  write_attribute(*this, obj.get(), object, name, H5T_STD_I64LE, H5T_NATIVE_INT64, space.get(), &value);
}

void File::set_attribute(std::string_view object, std::string_view name, std::span<const double> values) {
  Handle obj = open_object(object);
  const hsize_t dims[1] = {values.size()};
  Handle space(H5Screate_simple(1, dims, nullptr));
  write_attribute(*this, obj.get(), object, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, space.get(),
                  values.data());
}

bool File::has_attribute(std::string_view object, std::string_view name) const {
  Handle obj = open_object(object);
  const std::string n(name);
  return H5Aexists(obj.get(), n.c_str()) > 0;
}

namespace {

Handle open_attribute(const File& f, hid_t obj, std::string_view object, std::string_view name) {
  const std::string n(name);
  if (H5Aexists(obj, n.c_str()) <= 0) f.fail(object, "missing attribute " + n);
  Handle a(H5Aopen(obj, n.c_str(), H5P_DEFAULT));
  if (!a.valid()) f.fail(object, "cannot open attribute " + n);
  return a;
}

}  // namespace

std::string File::string_attribute(std::string_view object, std::string_view name) const {
  Handle obj = open_object(object);
  Handle a = open_attribute(*this, obj.get(), object, name);
  Handle type(H5Aget_type(a.get()));
  if (H5Tget_class(type.get()) != H5T_STRING) fail(object, "attribute " + std::string(name) + " is not a string");
  if (H5Tis_variable_str(type.get()) > 0) {
    char* text = nullptr;
    Handle mem(H5Tcopy(H5T_C_S1));
    H5Tset_size(mem.get(), H5T_VARIABLE);
    if (H5Aread(a.get(), mem.get(), &text) < 0) fail(object, "cannot read attribute " + std::string(name));
    std::string s = text ? text : "";
    H5free_memory(text);
    return s;
  }
  const std::size_t size = H5Tget_size(type.get());
  std::string s(size, '\0');
  if (H5Aread(a.get(), type.get(), s.data()) < 0) fail(object, "cannot read attribute " + std::string(name));
  s.resize(std::strlen(s.c_str()));
  return s;
}

double File::double_attribute(std::string_view object, std::string_view name) const {
  Handle obj = open_object(object);
  Handle a = open_attribute(*this, obj.get(), object, name);
  double v = 0;
  if (H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v) < 0) fail(object, "cannot read attribute " + std::string(name));
  return v;
}

std::int64_t File::int_attribute(std::string_view object, std::string_view name) const {
  Handle obj = open_object(object);
  Handle a = open_attribute(*this, obj.get(), object, name);
  std::int64_t v = 0;
  if (H5Aread(a.get(), H5T_NATIVE_INT64, &v) < 0) fail(object, "cannot read attribute " + std::string(name));
  return v;
}

std::vector<double> File::doubles_attribute(std::string_view object, std::string_view name) const {
  Handle obj = open_object(object);
  Handle a = open_attribute(*this, obj.get(), object, name);
  Handle space(H5Aget_space(a.get()));
  const hssize_t count = H5Sget_simple_extent_npoints(space.get());
  std::vector<double> v(static_cast<std::size_t>(std::max<hssize_t>(0, count)));
  if (!v.empty() && H5Aread(a.get(), H5T_NATIVE_DOUBLE, v.data()) < 0)
    fail(object, "cannot read attribute " + std::string(name));
  return v;
}

// ---- Dataset --------------------------------------------------------------------------------

Dataset::Dataset(const File* file, std::string path, Handle handle)
    : file_(file), path_(std::move(path)), handle_(std::move(handle)) {
  Handle space(H5Dget_space(handle_.get()));
  hsize_t dims[2] = {0, 1};
  rank_ = H5Sget_simple_extent_ndims(space.get());
  if (rank_ < 1 || rank_ > 2) fail("expected a one- or two-dimensional dataset");
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  rows_ = dims[0];
  width_ = rank_ == 2 ? dims[1] : 1;
  Handle type(H5Dget_type(handle_.get()));
  if (!classify(type.get(), type_)) fail("unsupported element type");
}

void Dataset::fail(std::string_view problem) const { file_->fail(path_, problem); }

std::uint64_t Dataset::stored_bytes() const { return H5Dget_storage_size(handle_.get()); }

std::uint64_t Dataset::element_bytes() const {
  Handle type(H5Dget_type(handle_.get()));
  return H5Tget_size(type.get());
}

bool Dataset::together(Transfer transfer) const {
  return transfer == Transfer::Collective && file_->parallel();
}

void Dataset::read_rows_raw(std::uint64_t first, std::uint64_t count, Type memory, void* out,
                            Transfer transfer) const {
  const bool collective = together(transfer);
  if (count == 0 && !collective) return;
  if (first + count > rows_) fail("rows out of range");
  const RowSelection selection = select_rows(handle_.get(), rank_, width_, first, count);
  double nothing = 0.0;
  if (count == 0) out = &nothing;
  const Handle dxpl = transfer_list(collective);
  if (H5Dread(handle_.get(), memory_type(memory), selection.mem_space.get(), selection.file_space.get(),
              list_or_default(dxpl), out) < 0)
    fail("read failed (rows " + std::to_string(first) + ".." + std::to_string(first + count) + ")");
  count_transfer(dxpl);
}

void Dataset::write_rows_raw(std::uint64_t first, std::uint64_t count, Type memory, const void* data,
                             Transfer transfer) {
  const bool collective = together(transfer);
  if (count == 0 && !collective) return;
  if (first + count > rows_) fail("rows out of range");
  const RowSelection selection = select_rows(handle_.get(), rank_, width_, first, count);
  const double nothing = 0.0;
  if (count == 0) data = &nothing;
  const Handle dxpl = transfer_list(collective);
  if (H5Dwrite(handle_.get(), memory_type(memory), selection.mem_space.get(), selection.file_space.get(),
               list_or_default(dxpl), data) < 0)
    fail("write failed (rows " + std::to_string(first) + ".." + std::to_string(first + count) + ")");
  count_transfer(dxpl);
}

void Dataset::read_selected_raw(std::span<const std::uint64_t> rows, Type memory, void* out,
                                Transfer transfer) const {
  const bool collective = together(transfer);
  if (rows.empty()) {
    if (collective) read_rows_raw(0, 0, memory, out, transfer);
    return;
  }
  // Runs of consecutive rows become one hyperslab block each: far cheaper than point
  // selections for the clustered rows of a halo.
  std::size_t i = 0;
  bool sorted = true;
  for (std::size_t j = 1; j < rows.size(); ++j) sorted = sorted && rows[j] > rows[j - 1];
  if (!sorted) fail("read_selected needs strictly increasing rows");
  if (rows.back() >= rows_) fail("rows out of range");
  std::size_t runs = 1;
  for (std::size_t j = 1; j < rows.size(); ++j) runs += rows[j] != rows[j - 1] + 1;
  if (collective || runs <= 32) {
    read_selection(rows, memory, out, collective);
    return;
  }
  // Many runs (the halo rows of a tile, scattered over its neighbours' rows): libhdf5 reads a
  // point selection element by element, far slower than copying whole blocks. Rows closer
  // than kGap to each other form a span, read as one block (at most kPiece rows, through a
  // buffer of that size) from which the selected rows are picked; spans of fewer than
  // kDense selected rows go through one point selection together.
  constexpr std::uint64_t kGap = 512, kPiece = std::uint64_t{1} << 15;
  constexpr std::size_t kDense = 8;
  const std::size_t row_bytes = H5Tget_size(memory_type(memory)) * width_;
  auto* const target = static_cast<unsigned char*>(out);
  std::vector<unsigned char> block;
  std::vector<std::uint64_t> sparse;
  std::vector<std::size_t> sparse_at;
  for (std::size_t j = 0; i < rows.size(); i = j) {
    for (j = i + 1; j < rows.size() && rows[j] - rows[j - 1] <= kGap && rows[j] - rows[i] < kPiece;) ++j;
    if (j - i < kDense) {
      for (std::size_t r = i; r < j; ++r) {
        sparse.push_back(rows[r]);
        sparse_at.push_back(r);
      }
      continue;
    }
    const std::uint64_t first = rows[i], count = rows[j - 1] - first + 1;
    block.resize(count * row_bytes);
    read_rows_raw(first, count, memory, block.data(), Transfer::Independent);
    for (std::size_t r = i; r < j; ++r)
      std::memcpy(target + r * row_bytes, block.data() + (rows[r] - first) * row_bytes, row_bytes);
  }
  if (sparse.empty()) return;
  block.resize(sparse.size() * row_bytes);
  read_selection(sparse, memory, block.data(), false);
  for (std::size_t r = 0; r < sparse.size(); ++r)
    std::memcpy(target + sparse_at[r] * row_bytes, block.data() + r * row_bytes, row_bytes);
}

void Dataset::read_selection(std::span<const std::uint64_t> rows, Type memory, void* out, bool collective) const {
  Handle file_space(H5Dget_space(handle_.get()));
  H5Sselect_none(file_space.get());
  std::size_t i = 0;
  std::size_t runs = 1;
  for (std::size_t j = 1; j < rows.size(); ++j) runs += rows[j] != rows[j - 1] + 1;
  if (runs <= 32) {
    // A few runs of consecutive rows: one hyperslab block each.
    while (i < rows.size()) {
      std::size_t j = i + 1;
      while (j < rows.size() && rows[j] == rows[j - 1] + 1) ++j;
      const hsize_t start[2] = {rows[i], 0}, extent[2] = {j - i, width_};
      H5Sselect_hyperslab(file_space.get(), H5S_SELECT_OR, start, nullptr, extent, nullptr);
      i = j;
    }
  } else {
    // Many runs: a point selection (libhdf5 1.10 merges many hyperslab blocks slowly).
    std::vector<hsize_t> coords(rows.size() * width_ * static_cast<std::size_t>(rank_));
    std::size_t c = 0;
    for (const std::uint64_t r : rows)
      for (hsize_t w = 0; w < width_; ++w) {
        coords[c++] = r;
        if (rank_ == 2) coords[c++] = w;
      }
    if (H5Sselect_elements(file_space.get(), H5S_SELECT_SET, rows.size() * width_, coords.data()) < 0)
      fail("cannot select rows");
  }
  const hsize_t mem_dims[2] = {rows.size(), width_};
  Handle mem_space(H5Screate_simple(rank_, mem_dims, nullptr));
  const Handle dxpl = transfer_list(collective);
  if (H5Dread(handle_.get(), memory_type(memory), mem_space.get(), file_space.get(), list_or_default(dxpl), out) < 0)
    fail("read failed (" + std::to_string(rows.size()) + " selected rows)");
  count_transfer(dxpl);
}

}  // namespace pointfair::tiles::h5
