// MPI collectives behind Ranks: barrier, exact maxima and sums, the shared file.
#include "pointfair/tiles/mpi_ranks.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <vector>

#include <mpi.h>

#include "pointfair/io/point_table.hpp"

namespace pointfair::tiles {

namespace {

int count_of(std::size_t n) {
  if (n > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw io::IoError("MPI: a reduction over more than 2^31 values");
  return static_cast<int>(n);
}

}  // namespace

MpiSession::MpiSession(int& argc, char**& argv) {
  // libhdf5 and pointfair call MPI from the main thread only (the kernels' threads never do).
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
}

MpiSession::~MpiSession() { MPI_Finalize(); }

MpiRanks::MpiRanks() {
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

void MpiRanks::barrier() { MPI_Barrier(MPI_COMM_WORLD); }

void MpiRanks::max(std::span<double> values) {
  if (size_ > 1)
    MPI_Allreduce(MPI_IN_PLACE, values.data(), count_of(values.size()), MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
}

void MpiRanks::max(std::span<std::uint64_t> values) {
  if (size_ > 1)
    MPI_Allreduce(MPI_IN_PLACE, values.data(), count_of(values.size()), MPI_UINT64_T, MPI_MAX, MPI_COMM_WORLD);
}

std::uint64_t MpiRanks::sum(std::uint64_t value) {
  std::uint64_t total = value;
  if (size_ > 1) MPI_Allreduce(&value, &total, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  return total;
}

void MpiRanks::sum(std::span<std::uint64_t> values) {
  if (size_ > 1 && !values.empty())
    MPI_Allreduce(MPI_IN_PLACE, values.data(), count_of(values.size()), MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
}

void MpiRanks::sum_below(std::span<std::uint64_t> values) {
  if (values.empty()) return;
  std::vector<std::uint64_t> mine(values.begin(), values.end());
  // MPI_Exscan leaves rank 0's buffer undefined.
  std::fill(values.begin(), values.end(), 0);
  if (size_ > 1)
    MPI_Exscan(mine.data(), values.data(), count_of(values.size()), MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  if (rank_ == 0) std::fill(values.begin(), values.end(), 0);
}

std::string MpiRanks::from_first(const std::string& text) {
  if (size_ <= 1) return text;
  std::uint64_t length = text.size();
  MPI_Bcast(&length, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  std::string out = rank_ == 0 ? text : std::string(static_cast<std::size_t>(length), '\0');
  if (length > 0) MPI_Bcast(out.data(), count_of(out.size()), MPI_CHAR, 0, MPI_COMM_WORLD);
  return out;
}

void MpiRanks::merge(std::span<double> values) {
  if (size_ <= 1 || values.empty()) return;
  std::vector<std::uint64_t> bits(values.size());
  std::memcpy(bits.data(), values.data(), values.size() * sizeof(double));
  MPI_Allreduce(MPI_IN_PLACE, bits.data(), count_of(bits.size()), MPI_UINT64_T, MPI_BOR, MPI_COMM_WORLD);
  std::memcpy(values.data(), bits.data(), values.size() * sizeof(double));
}

h5::File MpiRanks::open_shared(const std::filesystem::path& path) {
  const MPI_Comm comm = MPI_COMM_WORLD;
  return h5::File::open_parallel(path, &comm);
}

h5::File MpiRanks::create_shared(const std::filesystem::path& path) {
  if (size_ <= 1) return h5::File::create(path);
  const MPI_Comm comm = MPI_COMM_WORLD;
  return h5::File::create_parallel(path, &comm);
}

void abort_job(const std::string& program, const std::string& message, int exit_code) {
  int rank = 0, size = 1, initialized = 0;
  MPI_Initialized(&initialized);
  if (initialized) {
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
  }
  std::fprintf(stderr, "%s: rank %d of %d: %s\n", program.c_str(), rank, size, message.c_str());
  std::fflush(stderr);
  if (initialized) MPI_Abort(MPI_COMM_WORLD, exit_code);
  std::_Exit(exit_code);
}

}  // namespace pointfair::tiles
