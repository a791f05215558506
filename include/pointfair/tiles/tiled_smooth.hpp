#pragma once
// The evolution of smooth() run out of core: tiles of a container (see container.hpp) are
// streamed through memory with a halo, every step is committed atomically in the output
// file, and the result is bit-identical to the in-core smooth() with the same parameters.
//
// How it stays exact:
// - neighbourhoods are built per tile from the tile plus every point within a halo of
//   width eps (grown until the (k+1)-th distance of every tile point is inside the halo when
//   eps is unbounded); local arrays are sorted by original index, so the tie rule of the
//   canonical order (ties by the smaller original index) is the in-core one;
// - the automatic eps and lambda are the in-core reductions over the same strided samples
//   (in original point order), computed from gathered values;
// - each point's step reads only its own step-n position and its neighbours' (Jacobi), in
//   the list order, so any tiling gives the same bits.
// - rebuilds (SmoothParams::rebuild_interval) resolve eps again and build the lists the same
//   way from the step's positions, with halos around the tiles' current bounds.
// - a compensated step (SmoothParams::shrink_compensation) needs the plain updates of a
//   point's neighbours, hence the 2-ring closure of the tile's lists: such steps load each
//   tile with it (as temporal blocks do, two rings a step) and compensate in list order.
// - the automatic stops (stop_lambda_ratio, stop_plateau) see the lambda of every step so
//   far; a resumed run reads those of the steps before it from the run's step log.
// - the quadric finish (quadric_projection.hpp), after the last step, pass by pass: each
//   tile gathers the pass's positions of its points and of a halo grown until it holds every
//   point's k nearest, and the normal_neighbors nearest of every halo point in those lists
//   (whose normals decide which neighbours a fit keeps); the tile's points are projected as
//   in core (the last pass places the input points along the normals: SmoothParams::
//   placement) and each pass is committed like a step. A pass reads, computes and writes one
//   tile after the other (no pipeline: the fits, not the I/O, take its time).
// - the coarse level (SmoothParams::coarse; src/tiles/coarse/), before all this: each tile
//   draws the coarse sample of its points with a halo of one sample cell (a cell's points
//   decide its sample), the sample's own run is a run like this one, each tile moves its
//   points by the coarse points of a halo grown until every point's nearest are certain, and
//   this run starts from the moved points (OutOfCoreOptions::start_positions).
//
// Each step is a bounded pipeline (pipeline.hpp): tile i+1 and its halo are read while tile
// i is computed (parallel_for) and tile i-1 written; every HDF5 call stays on the calling
// thread, and the buffers of the tiles in flight count in the memory budget.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "pointfair/common/params_error.hpp"
#include "pointfair/finish/quadric_projection.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/tiles/budget.hpp"

namespace pointfair::tiles {

class Ranks;

/// The memory budget is too small for the run's tiles (a ParamError). Where the run file was
/// made by then, "<output>.partial" keeps what is committed, and a resume with a larger budget
/// continues it.
class BudgetError : public ParamError {
 public:
  BudgetError(const std::string& message, std::uint64_t budget_bytes, std::uint64_t needed_bytes)
      : ParamError(message), budget(budget_bytes), needed(needed_bytes) {}
  std::uint64_t budget = 0;  // bytes
  std::uint64_t needed = 0;  // bytes the run would have held
};

/// Bytes as whole MiB, or as KiB below one MiB ("300 KiB", "61 MiB"); rounded up with `up`.
std::string size_text(std::uint64_t bytes, bool up = false);

struct OutOfCoreOptions {
  /// Bytes of working memory the run may use for its buffers (tile, halo, neighbour lists,
  /// caches). libhdf5's chunk caches and the program itself come on top (a few tens of MiB).
  std::uint64_t memory_budget = kDefaultMemoryBudget;
  /// Continue the interrupted run in "<output>.partial" instead of refusing to start.
  bool resume = false;
  /// Compute the per-point attributes (normals, curvatures, feature classes) at the end.
  bool attributes = true;
  /// Tiles in flight in each step's pipeline (pipeline.hpp): one read, one computed, one
  /// written. Fewer when they do not fit in the budget next to what the run keeps; 1: read,
  /// compute and write one tile after the other. Results do not depend on it. While the
  /// positions are held in memory in the lists' order (OutOfCoreReport::positions_held), a
  /// slot holds no positions and every tile of a step is in flight.
  int tiles_in_flight = 3;
  /// Temporal blocking: steps done per load of a tile, which comes with the h-ring closure of
  /// its neighbour lists (every point its step-n+h position depends on; the 2h-ring closure
  /// with SmoothParams::shrink_compensation), to cut the I/O of halos and lists. Needs a lambda
  /// that stays fixed between steps (a fixed lambda, or one measured once); blocks end at
  /// rebuilds, and with SmoothParams::momentum a block is one step (a point's last move is
  /// known only for the step after it). 1: one step per load. Results do not depend on it.
  int temporal_block = 1;
  /// Streamed steps (single process, one step per load, positions not held) keep each tile's
  /// halo in a scratch file beside the output, written by the tiles that hold its points, and
  /// read it with one read a tile instead of a selection of scattered rows of the run file
  /// (src/tiles/run/halo_scratch.hpp). Takes 48 bytes of disk per halo point, unlinked: nothing is
  /// left behind. Off, or where the scratch cannot be made or does not fit in the budget: the
  /// halos are read from the run file. Results do not depend on it.
  bool halo_scratch = true;
  /// Streamed single steps without shrinkage compensation (single process, halo_scratch on,
  /// lists not cached, positions not held) go through temporal blocks of one step: each tile's
  /// lists in local indices from a scratch file made once (mapped, one read a tile) and its
  /// halo from the blocks' ring scratch, the tile kept in its lists' order from step to step.
  /// Off, or where that scratch cannot be made or does not fit in the budget: the halo scratch
  /// above. Results do not depend on it.
  bool step_blocks = true;
  /// Build the first neighbourhoods from this cloud instead of the input (SmoothOptions::
  /// neighbor_reference): a point file or container with the same points in the input's
  /// original order. Its positions are copied into the run in row order, in passes over
  /// blocks of an eighth of the budget (each reads the reference again). The coarse level
  /// (SmoothParams::coarse) does not run then, as in core. Empty: the input.
  std::filesystem::path neighbor_reference;
  /// Start the flow from this container's positions instead of the input's (the coarse
  /// level's moved points): a container with the input's tiles and rows, as many points. The
  /// input's positions stay the points the finish places along the normals (SmoothParams::
  /// placement), as SmoothOptions::input_positions in core; the automatic k, eps and lambda
  /// and the first neighbourhoods are measured on the start. Copied into the run (24 bytes a
  /// point of disk). Empty: the input.
  std::filesystem::path start_positions;
  /// Stop (as if killed) after this many steps committed by this call; < 0: never. For tests.
  int stop_after_steps = -1;
  /// Stop (as if killed) after this many finish passes committed by this call; < 0: never.
  /// For tests.
  int stop_after_finish_passes = -1;
  /// Called with a phase name ("eps", "neighbors", "step", "finish", "attributes") and
  /// progress (of this rank's tiles in the per-tile phases).
  std::function<void(const std::string&, std::uint64_t, std::uint64_t)> progress;
  /// The processes sharing the run (ranks.hpp), each calling smooth_out_of_core with the same
  /// arguments; each builds the neighbourhoods of and steps its own contiguous range of tiles
  /// (balanced by points plus halo), and every step is committed once all ranks wrote it.
  /// Null: this process alone. The memory budget holds per rank.
  Ranks* ranks = nullptr;
};

struct OutOfCoreReport {
  std::uint64_t points = 0;
  std::size_t tiles = 0;
  /// Steps done in total, and those already committed when this call started.
  int steps = 0;
  int resumed_from = 0;
  bool finished = false;
  double eps = 0.0;
  /// The neighbourhood size used (the automatic choice or neighbors.k).
  int k = 0;
  /// The cut-off threshold of the last step (as SmoothReport::lambda).
  double lambda = 0.0;
  std::size_t degenerate = 0;
  /// Neighbour lists kept in memory across steps (they fit in the budget) or re-read.
  bool neighbors_cached = false;
  /// The steps' positions kept in memory as well (every tile's lists cached, two copies of
  /// every tile with its halo fit in the budget, three with SmoothParams::shrink_compensation,
  /// every halo in this rank's tiles): each step still goes to the run file and is committed,
  /// but is read from the file by the first step only.
  bool positions_held = false;
  /// Streamed steps read their halos from the scratch file (OutOfCoreOptions::halo_scratch).
  bool halo_scratch = false;
  /// Plain streamed steps ran as blocks of one step (OutOfCoreOptions::step_blocks).
  bool step_blocks = false;
  /// The largest working set the run accounted for (bytes), and the largest tile + halo.
  std::uint64_t peak_accounted_bytes = 0;
  std::uint64_t largest_tile_with_halo = 0;
  /// Tiles (counted once a finish pass) whose finish ran in parts: the whole tile with its
  /// halo would not have fitted the budget.
  std::uint64_t finish_tiles_in_parts = 0;
  /// The most tiles in flight in a step's pipeline (OutOfCoreOptions::tiles_in_flight, or
  /// fewer; every tile of a step while positions are held in the lists' order).
  int tiles_in_flight = 1;
  /// Halo rows a step reads, summed over the tiles (the I/O of a step beyond the tiles
  /// themselves); 0 when the run file does not record them.
  std::uint64_t halo_points = 0;
  /// Rows of positions (24 bytes each) and of neighbour lists (4 k + 2 bytes each) the steps
  /// of this call read: their I/O volume beyond the rows they write.
  std::uint64_t position_rows_read = 0;
  std::uint64_t list_rows_read = 0;
  /// Neighbourhood rebuilds done by this call (SmoothParams::rebuild_interval).
  int rebuilds = 0;
  /// Steps of this call whose momentum was dropped because the noise gauge rose
  /// (SmoothParams::momentum, SmoothReport::momentum_restarts).
  int momentum_restarts = 0;
  /// Quadric finish passes done in total (SmoothParams::finish).
  int finish_passes = 0;
  /// Why the flow stopped, where this call ran its last step or found the automatic stop
  /// (SmoothReport::stop_reason); empty when it resumed a run whose steps had ended.
  std::optional<StopReason> stop_reason;
  /// The coarse levels that ran (SmoothParams::coarse), finest first, as SmoothReport's.
  std::vector<CoarseLevelReport> coarse_levels;
  double seconds_coarse = 0.0;
  double seconds_neighbors = 0.0;
  double seconds_steps = 0.0;
  double seconds_finish = 0.0;
  double seconds_attributes = 0.0;
};

/// Name of the working file of a run writing `output`: "<output>.partial".
std::filesystem::path partial_name(const std::filesystem::path& output);

/// The work folder of the coarse level (SmoothParams::coarse) of a run writing `output`:
/// "<output>.partial.coarse", kept with the partial file for a resume.
std::filesystem::path coarse_folder_name(const std::filesystem::path& output);
/// Removes the files a run makes in that folder, and the folder when it is then empty. Never
/// throws.
void remove_coarse_folder(const std::filesystem::path& output);

/// Runs `params` on the container `input` (never modified) and writes a container with the
/// run to `output`: first into partial_name(output), renamed to `output` when finished.
/// Throws ParamError (bad parameters; a tile that does not fit in the budget; a partial run
/// with other parameters), IoError (files).
OutOfCoreReport smooth_out_of_core(const std::filesystem::path& input,
                                   const std::filesystem::path& output, const SmoothParams& params,
                                   const OutOfCoreOptions& options = {});

}  // namespace pointfair::tiles
