#pragma once
// The ranks of an MPI job as the Ranks of an out-of-core run (ranks.hpp). Only in builds
// configured with -DPOINTFAIR_MPI=ON (target pointfair::tiles_mpi, OpenMPI and parallel
// HDF5); the header keeps <mpi.h> out.
#include <string>

#include "pointfair/tiles/ranks.hpp"

namespace pointfair::tiles {

/// MPI_Init on construction, MPI_Finalize on destruction (one per process).
class MpiSession {
 public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
};

/// The ranks of MPI_COMM_WORLD. Collective operations are MPI collectives; a rank that
/// fails stops the job with abort_job() instead of leaving the others waiting.
class MpiRanks final : public Ranks {
 public:
  MpiRanks();
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void barrier() override;
  void max(std::span<double> values) override;
  void max(std::span<std::uint64_t> values) override;
  std::uint64_t sum(std::uint64_t value) override;
  void sum(std::span<std::uint64_t> values) override;
  void sum_below(std::span<std::uint64_t> values) override;
  std::string from_first(const std::string& text) override;
  void merge(std::span<double> values) override;
  h5::File open_shared(const std::filesystem::path& path) override;
  h5::File create_shared(const std::filesystem::path& path) override;

 private:
  int rank_ = 0, size_ = 1;
};

/// Prints "<program>: rank R of N: <message>" to stderr and ends every rank of the job
/// (MPI_Abort with `exit_code`).
[[noreturn]] void abort_job(const std::string& program, const std::string& message, int exit_code);

}  // namespace pointfair::tiles
