#pragma once
// The processes that share one out-of-core run (see tiled_smooth.hpp). A plain run is one
// rank: this base class, whose operations do nothing. pointfair_mpi passes the ranks of its
// MPI communicator (mpi_ranks.hpp, built with -DPOINTFAIR_MPI=ON), so the same run code
// drives one process or many.
//
// Every rank calls every operation in the same order (they are collective); values are
// combined exactly (maxima and integer sums), so the result does not depend on the number of
// ranks.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>

#include "pointfair/tiles/hdf5_file.hpp"

namespace pointfair::tiles {

class Ranks {
 public:
  virtual ~Ranks() = default;
  /// This process's rank in 0..size()-1; rank 0 creates and finishes the run's file.
  virtual int rank() const { return 0; }
  virtual int size() const { return 1; }
  /// Returns once every rank has called it.
  virtual void barrier() {}
  /// Element-wise maximum over the ranks, in place.
  virtual void max(std::span<double> /*values*/) {}
  virtual void max(std::span<std::uint64_t> /*values*/) {}
  /// Sum over the ranks.
  virtual std::uint64_t sum(std::uint64_t value) { return value; }
  /// Element-wise sum over the ranks, in place.
  virtual void sum(std::span<std::uint64_t> /*values*/) {}
  /// Element-wise sum over the ranks below this one, in place (zeros on rank 0).
  virtual void sum_below(std::span<std::uint64_t> values) { std::fill(values.begin(), values.end(), 0); }
  /// Rank 0's `text` on every rank.
  virtual std::string from_first(const std::string& text) { return text; }
  /// Each value is held by one rank, the others hold +0.0 there: afterwards every rank holds
  /// every value, bit for bit (a bitwise or of the ranks' bits).
  virtual void merge(std::span<double> /*values*/) {}
  /// Opens the existing file `path` for reading and writing on every rank, for parallel I/O.
  virtual h5::File open_shared(const std::filesystem::path& path) { return h5::File::open(path, true); }
  /// Creates (truncating) `path` on every rank, for parallel I/O.
  virtual h5::File create_shared(const std::filesystem::path& path) { return h5::File::create(path); }
};

}  // namespace pointfair::tiles
