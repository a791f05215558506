#pragma once
// The out-of-core half of the throughput tool: a cloud imported into a container in a
// temporary directory (the path of `pointfair import IN OUT.h5 --memory-budget SIZE`), then
// steps run out of core on it (smooth_out_of_core, as `pointfair smooth IN.h5 OUT.h5
// --memory-budget SIZE`), timed like the in-core steps: the steps only, from the run's report.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "pointfair/smooth.hpp"
#include "pointfair/tiles/budget.hpp"

namespace pointfair::bench {

/// The streamed section's temporal block unless the command line sets one: on the 1M-point
/// cube in 16 tiles at 61M, blocks of 4 steps run the isotropic step at 2 threads at about
/// twice the rate of single steps, which stream every tile's lists, halo and positions.
constexpr int kStreamedTemporalBlock = 4;

struct OutOfCoreRateOptions {
  /// The run's memory budget (OutOfCoreOptions::memory_budget), bytes.
  std::uint64_t memory_budget = tiles::kDefaultMemoryBudget;
  /// Most points per tile of the import; 0: the rule `pointfair import --memory-budget` uses.
  std::uint64_t tile_points = 0;
  /// Steps per load of a tile (OutOfCoreOptions::temporal_block).
  int temporal_block = 1;
};

struct OutOfCoreRate {
  double point_steps_per_second = 0.0;
  double seconds_steps = 0.0;
  int steps = 0;
  std::size_t tiles = 0;
  /// Whether the neighbour lists stayed in memory across steps, and the tiles in flight.
  bool neighbors_cached = false;
  int tiles_in_flight = 0;
  /// Whether the steps' positions stayed in memory too (OutOfCoreReport::positions_held).
  bool positions_held = false;
  /// Whether streamed steps read their halos from the halo scratch (OutOfCoreReport::halo_scratch).
  bool halo_scratch = false;
  /// Whether plain streamed steps ran as blocks of one step (OutOfCoreReport::step_blocks).
  bool step_blocks = false;
  /// The run's final positions equal smooth()'s on the same cloud to the bit (when checked).
  bool checked = false;
  bool identical = false;
};

/// One row of the tool's out-of-core table: a flow and thread count, out of core and in core
/// back to back (medians over the repeats, and the median of the paired ratios: the machine's
/// load changes less within a pair than over the whole run).
struct OutOfCoreRow {
  std::string flow;  // "iso" or "aniso"
  int threads = 1;
  double in_core = 0.0;      // point-steps/s
  double out_of_core = 0.0;  // point-steps/s
  double ratio = 0.0;        // out of core / in core
  bool identical = false;    // the out-of-core result equals the in-core one to the bit
};

struct OutOfCoreSection {
  OutOfCoreRateOptions options;
  std::uint64_t tile_points = 0;
  std::size_t tiles = 0;
  bool neighbors_cached = false;
  bool positions_held = false;
  bool halo_scratch = false;
  bool step_blocks = false;
  int tiles_in_flight = 0;
  /// The automatic lambda measured once rather than every step, in both runs of every pair:
  /// temporal blocks (temporal_block > 1) need a lambda that stays fixed between steps.
  bool lambda_once = false;
  std::vector<OutOfCoreRow> rows;
};

/// Imports `cloud` and measures iso and aniso steps (`params_for(flow)`) out of core and in
/// core for 1..`cores` threads, `repeats` pairs each. With options.temporal_block > 1, an
/// automatic lambda of every step becomes one measured once (lambda_every_step off), for the
/// in-core run of each pair as well. Throws what smooth_out_of_core throws.
OutOfCoreSection measure_out_of_core(const std::vector<Vec3>& cloud, int k, int cores, int repeats,
                                     const std::function<SmoothParams(Flow)>& params_for,
                                     const OutOfCoreRateOptions& options);
/// The section as lines of the tool's table, and as a JSON member (`name`: {...}).
void print_out_of_core(const OutOfCoreSection& section);
std::string out_of_core_json(const OutOfCoreSection& section, const std::string& name = "out_of_core");

/// A budget too small for the run to keep a cloud of `points` points in memory between steps
/// (its neighbour lists alone take (k + 1) 4 bytes a point): 64 bytes a point, at least 16 MiB.
std::uint64_t streamed_budget(std::uint64_t points);

/// A generated cloud imported once into a container in a fresh temporary directory, removed
/// with the object.
class OutOfCoreBench {
 public:
  OutOfCoreBench(const std::vector<Vec3>& cloud, int k, const OutOfCoreRateOptions& options);
  ~OutOfCoreBench();
  OutOfCoreBench(const OutOfCoreBench&) = delete;
  OutOfCoreBench& operator=(const OutOfCoreBench&) = delete;

  /// Runs `params` out of core on the container (the output is removed afterwards). With
  /// `expected` non-empty (smooth()'s positions for the same params), compares the result.
  OutOfCoreRate run(const SmoothParams& params, const std::vector<Vec3>& expected = {}) const;

  std::uint64_t tile_points() const { return tile_points_; }
  std::size_t tiles() const { return tiles_; }

 private:
  std::filesystem::path dir_, container_;
  OutOfCoreRateOptions options_;
  std::uint64_t tile_points_ = 0;
  std::size_t tiles_ = 0;
};

}  // namespace pointfair::bench
