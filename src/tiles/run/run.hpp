#pragma once
// The out-of-core run (smooth_out_of_core): its commit record, and the Run that creates or
// resumes the run file, builds the tiles' neighbourhoods, streams the steps, runs the finish
// and writes the attributes. Its parts, in the order a run goes through them:
//   run.cpp            the run file, its state and commit record, resume
//   neighbors.cpp      neighbourhoods, eps and k, the lambda sample
//   lists.cpp          the steps' lists, halos, the halo and block scratch
//   steps.cpp          the step loop every strategy shares: lambda, automatic stop, commits
//   held_step.cpp      a step over positions held in memory (the strategy while they fit)
//   streamed_step.cpp  a step streaming each tile and its halo from the run file
//   block_step.cpp     a step or temporal block over a tile's ring closure (BlockSlot)
//   momentum_step.cpp  momentum: its rules from the logged lambdas, each tile's last moves
//   finish.cpp         the quadric finish, the attributes and the end
#include <algorithm>
#include <array>
#include <cassert>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <numeric>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/finish/quadric_projection.hpp"
#include "pointfair/flow/shrink_compensation.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/file_lock.hpp"
#include "pointfair/tiles/budget.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/neighbors/nearest_points.hpp"
#include "pointfair/neighbors/neighborhood_size.hpp"
#include "pointfair/neighbors/spatial_order.hpp"
#include "pointfair/tiles/balance.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/container_reader.hpp"
#include "pointfair/tiles/pipeline.hpp"
#include "pointfair/tiles/ranks.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"
#include "halo_scratch.hpp"
#include "scratch_file.hpp"
#include "row_map.hpp"
#include "block_slot.hpp"
#include "tile_moves.hpp"
#include "tile_lists.hpp"
#include "vector_bytes.hpp"

namespace pointfair::tiles::detail {

namespace fs = std::filesystem;

using Clock = std::chrono::steady_clock;
inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Slots of /run/state, the commit record: one small contiguous dataset rewritten in place.
// kStepBuffer: where the positions of step kCompletedSteps are (0: the input; 1, 2:
// positions_0, positions_1 in row order; 3, 4: the same buffers with each tile's rows in the
// order of its lists, kLocalOrder, as the steps write them while positions are held in memory,
// see Run::to_row_order); a step or temporal block writes into the other buffer.
// kNeighborsStep: the step whose positions the stored neighbour lists were built from (0: the
// input or the reference; a rebuild at step s overwrites them in place and records s).
// kFinishPasses: quadric finish passes done (SmoothParams::finish); a pass writes
// the other buffer like a step, and kStepBuffer then names the pass's result. Only runs with
// the finish have that slot: the others keep the record of kLegacyStateSize slots that runs
// started before the finish existed have.
enum StateSlot {
  kSetupDone = 0,
  kNeighborsDone = 1,
  kCompletedSteps = 2,
  kFinished = 3,
  kNeighborsStep = 4,
  kStepBuffer = 5,
  kFinishPasses = 6,
  kStateSize = 7
};
inline constexpr std::size_t kLegacyStateSize = 6;

// Rows read at a time when filtering whole tiles for halos.
inline constexpr std::uint64_t kScanBlock = 1u << 15;
// A computed distance is trusted to decide "inside the halo" only with this relative margin.
inline constexpr double kHaloMargin = 1e-9;

// SmoothOptions::neighbor_reference out of core: the reference's positions in row order.
inline constexpr const char* kReferencePositions = "/run/reference_positions";
// OutOfCoreOptions::start_positions: the positions of step 0 in row order.
inline constexpr const char* kStartPositions = "/run/start_positions";
// Per row of /run/neighbors/local: which tile row the list belongs to (see TileNeighbors).
// Absent from runs started by an older version: their lists stay in row order.
inline constexpr const char* kLocalOrder = "/run/neighbors/local_order";
// The lambda of an automatic stop (smooth()'s, measured on the final step's positions), kept
// with the first finish pass: a resumed finish no longer has those positions to measure.
inline constexpr const char* kStopLambda = "/run/finish_stop_lambda";

inline std::string positions_buffer(int parity) { return "/run/positions_" + std::to_string(parity); }
// The momentum's last moves of every point before step `step` (SmoothParams::momentum), in row
// order: step s reads the buffer of s and writes that of s + 1, so that a step killed before
// its commit leaves the moves it read for the step done again.
inline std::string moves_buffer(int step) { return "/run/moves_" + std::to_string(step % 2); }

// Every parameter that changes the result, as one line: stored in the run and compared on
// --resume.
std::string parameters_key(const SmoothParams& p);
// Every parameter of the quadric finish, for the same line.
std::string finish_key(const QuadricProjectionParams& q);

// One tile in flight in a plain step's pipeline (held or streamed; a block's is a BlockSlot).
struct StepSlot {
  std::size_t tile = 0;
  std::shared_ptr<const TileNeighbors> nb;
  std::shared_ptr<TileNeighbors> own;  // lists read for this slot, reused from tile to tile
  // A streamed step: `local` was read in the lists' order (a source in list order), and
  // where row r of the tile sits in it (for the lambda sample of a step written in list order).
  bool read_in_list_order = false;
  std::vector<Index> slot_of;
  // With lists in Morton order (TileNeighbors::order), the tile's rows are read into `next`
  // (row order) and moved into `local`; the step writes `next`, moved back into the first
  // rows of `local` in row order.
  std::vector<Vec3> local, next;
  TileMoves moves;  // with momentum: the tile's last moves, in the order of `local`
  StepStats stats;
  const std::vector<Vec3>& result() const { return nb->order.empty() ? next : local; }
};

// What the steps of one call of Run::run_steps share: the tiles, the pipeline's slots, and
// the commit or writes a step leaves to the next.
struct StepWork {
  std::vector<std::size_t> tiles;  // this rank's tiles with points
  std::vector<Index> identity;     // 0, 1, ...: the rows a tile's step computes
  // Collective writes a step makes: as many per rank as the rank with the most tiles.
  std::uint64_t writes = 0;
  std::size_t slot_count = 1;
  std::vector<StepSlot> slots;
  std::vector<BlockSlot> block_slots;
  // The commit of a step (commit_state) mostly waits for the disk. In a single process it is
  // left pending and finished by this thread while the worker computes the next step's first
  // tile: before the next step writes anything (it overwrites the buffer the commit leaves
  // behind), before anything else touches the file, and before run_steps returns. The step's
  // progress is reported once it is committed, as before.
  bool commit_pending = false;
  // A held step in list order in a single process goes further: it leaves its writes to the
  // next step, whose pipeline reads nothing from the file, so this thread writes the tiles
  // (from the held buffer: the next step only reads it) and commits them while the worker
  // computes. The step's computes then follow the last one's without waiting for its last
  // tile to be written. `record` is the state to commit once its tiles are written.
  struct Lagged {
    bool pending = false;
    int buffer = 0;
    std::string target;
    std::vector<std::int64_t> record;
    std::size_t written = 0;  // items of `tiles` written
  } lagged;
};

// What one step (or temporal block) does, decided before its pipeline runs (Run::plan_step),
// and what its stages count. The strategies' stages read and fill it.
struct StepPlan {
  int step = 0;
  int h = 1;  // steps in this block (1 but for temporal blocks)
  double lambda = 0.0;
  // The positions the step reads and the buffer it writes (named target_name).
  std::optional<h5::Dataset> source, target;
  std::string target_name;
  // The lambda sample's positions after this step (or block), gathered as its tiles are
  // written: only where the next step measures the lambda (smooth()'s rule: every step of
  // the anisotropic flow, the last of the isotropic one). A resumed run reads them anew.
  bool gather_sample = false;
  // Whether this step writes its positions in list order (held_list_order_): not the last
  // step, nor one before a rebuild, which write row order as they go instead of after.
  bool list_order_step = false;
  // Whether its writes go to the next step (StepWork::Lagged): not where the run stops after it.
  bool lag_writes = false;
  // Streamed steps write list order too, on the same terms, while the halo scratch carries
  // the halos (the run file's rows of a halo are then not in row order) and every tile's
  // lists have an order; the slots then hold no copy of a tile in row order.
  HaloScratch* halos = nullptr;
  bool streamed_list_order = false;
  // The buffer of the halo (or ring) scratch this step writes.
  int written_halos = 0;
  // Blocks with their lists and rings from the scratch; those of them that write list order.
  bool scratch_block = false, block_list_order = false;
  // Degenerate points per step of the block; of a plain step.
  std::vector<std::size_t> block_degenerate;
  std::size_t degenerate = 0;
  // Its momentum (momentum_of_step), and whether it writes its moves for the next step: the
  // datasets it reads them from and writes them to.
  double momentum = 0.0;
  bool writes_moves = false;
  std::optional<h5::Dataset> moves_source, moves_target;
  // A compensated held step's plain updates (held_step.cpp), per tile, once made.
  std::vector<StepStats> plain_stats;
  bool updated_ready = false;
};

class Run {
 public:
  Run(const fs::path& input, const fs::path& output, const SmoothParams& params, const OutOfCoreOptions& options)
      : input_path_(input), output_(output), params_(params), options_(options),
        ranks_(options.ranks != nullptr ? options.ranks : &single_) {}

  OutOfCoreReport run();
  // estimate_noise() of the input's positions (of OutOfCoreOptions::start_positions when
  // given), the same bits, from strided samples each found in its tile and a halo; every rank
  // takes part. Makes no file.
  NoiseEstimate measure_noise();

 private:
  void read_input_tables();
  void open_or_create();
  void create(const fs::path& partial, const std::string& digest);
  void share();
  void release();
  void commit_state() { commit_state(state_); }
  // Commits `record` (a copy of state_ as it was after a step whose writes came later).
  void commit_state(const std::vector<std::int64_t>& record);
  void balance(bool with_halo);
  std::uint64_t my_tiles() const;
  std::uint64_t tiles_to_write() const;
  std::uint64_t my_first_row() const { return tiles_.offsets[first_tile_]; }
  std::uint64_t my_end_row() const { return tiles_.offsets[end_tile_]; }
  void build_neighbors(int step);
  std::string key() const;
  // What the run continues: a digest of the input's positions and tile table (and of the
  // reference's bytes with neighbor_reference), stored in the run and compared on --resume.
  std::string input_digest() const;
  void load_reference();
  void measure_bounds();
  void rebuild_neighbors(int step);
  bool rebuild_due(int step) const {
    return params_.rebuild_interval > 0 && step > 0 && step % params_.rebuild_interval == 0;
  }
  double resolve_eps_tiled();
  // measure_noise() on the open file_ (the input, or the start positions' container).
  NoiseEstimate noise_tiled();
  // The tile table and bounds of the positions step 0 starts from (the input's, or
  // OutOfCoreOptions::start_positions'), with that file open as file_.
  void open_step0_positions();
  // OutOfCoreOptions::start_positions copied into kStartPositions (this rank's rows).
  void load_start();
  std::string step0_source() const {
    return options_.start_positions.empty() ? std::string(layout::positions) : std::string(kStartPositions);
  }
  // Calls measure(sample, indices, squared distances, local positions, the sample's local
  // index) for every point of this
  // rank's tiles whose original index is a multiple of `stride`, with its `want` nearest points
  // (itself included) among its tile and a halo grown until it holds them all. Concurrent.
  template <class Measure>
  void for_each_sample_knn(std::uint64_t stride, int want, const char* stage, Measure&& measure);
  double first_halo(std::size_t t) const;
  double knn_first_halo(std::size_t t, int neighbors) const;
  // The first halo of a box holding `box_rows` points.
  double knn_first_halo(const Box& box, std::uint64_t box_rows, int neighbors) const;
  bool covers_all(std::size_t t, double halo) const;
  bool covers_all(const Box& box, double halo) const;
  LocalSet gather_local(std::size_t t, double halo) const;
  // Part `part` of tile t with its halo (LocalSet::queries: the part's rows); nullopt when it
  // holds more than `max_points` points.
  std::optional<LocalSet> gather_part(std::size_t t, double halo, const TilePart& part,
                                      std::uint64_t max_points) const;
  void prepare_lambda_sample();
  // The automatic lambda of the positions last named by load_sample_positions (and, when the
  // sample is gathered, brought up to date by the steps' writes).
  double sample_lambda();
  // The sample's positions from `positions` (row order): read when the sample is gathered,
  // else only the dataset named, which sample_lambda then reads in pieces.
  void load_sample_positions(const h5::Dataset& positions);
  // sample_lambda of a sample that is not gathered: the medians of this rank's samples, a few
  // hundred at a time, each piece's lists and positions read from the run file.
  double sample_lambda_in_pieces();
  // The lambda sample's positions among a written tile's rows begin .. begin + rows - 1:
  // position_of(r) is the position of row begin + r.
  template <class PositionOf>
  void gather_sample_rows(std::uint64_t begin, std::uint64_t rows, PositionOf&& position_of);
  TileNeighbors tile_neighbors(std::size_t t) const;
  // Tile t's lists: cached, or read into `storage` (when given: its buffers are reused).
  std::shared_ptr<const TileNeighbors> neighbors_of(std::size_t t, std::shared_ptr<TileNeighbors> storage = {});
  // The scratch of streamed steps' halos (HaloScratch), made once every tile's halo is known;
  // null when off or not possible.
  HaloScratch* streamed_halos();
  // Every tile's lists have an order (TileNeighbors::order, in kLocalOrder).
  bool streamed_lists_ordered() const {
    for (std::size_t t = first_tile_; t < end_tile_; ++t)
      if (tiles_.rows(t) > 0 && local_written_[t] != 2) return false;
    return true;
  }
  void prepare_lists(OutOfCoreReport& report);
  std::size_t pipeline_slots(std::uint64_t fixed);
  // Tile t's positions (and halo) of `source` into `local` in the lists' order: the tile's
  // rows read into `scratch` and moved (here when `reorder`, else by the caller), or read as
  // they are when the source holds them in the lists' order (`listed`). The halo from buffer
  // `halo_buffer` of the halo scratch when it is 0 or 1.
  void read_tile_positions(std::size_t t, const TileNeighbors& nb, const h5::Dataset& source,
                           std::vector<Vec3>& local, std::vector<Vec3>& scratch, bool reorder = true,
                           int halo_buffer = -1, bool listed = false) const;
  // The steps (steps.cpp): every step from the state's, through the pipeline of the strategy
  // that fits, committed one by one; false when OutOfCoreOptions::stop_after_steps ended them.
  bool run_steps(OutOfCoreReport& report);
  // The lambda the first step of this call starts from when it is not measured every step.
  double lambda_at_start(int start, bool every_step);
  // The lambdas the automatic stop and the momentum read (stop_reason, momentum_of_step), as
  // smooth() keeps them (measured before step 0, then before each step that measures one):
  // those of the steps before `start` from the step log, then each step's as it comes (true
  // where it rose).
  std::vector<double> logged_lambdas(int start);
  bool note_lambda(int step, double lambda, std::vector<double>& lambdas) const;
  // Momentum out of core (momentum_step.cpp). The step's momentum and moves (StepPlan::momentum, writes_moves); counts a restart.
  void plan_momentum(StepPlan& plan, bool lambda_rose, std::span<const double> lambdas, OutOfCoreReport& report);
  // Tile t's last moves before the step into moves.listed, in the order `order` gives its
  // points (none where the step has no momentum).
  void read_moves(const StepPlan& plan, std::size_t t, std::span<const Index> order, TileMoves& moves) const;
  // The step's moves of tile t (moves.listed, in `order`) into the run file, for the next step.
  void write_moves(StepPlan& plan, std::size_t t, std::span<const Index> order, TileMoves& moves);
  StepWork start_step_work(OutOfCoreReport& report);
  // The neighbourhoods rebuilt before `step`, and what depends on them.
  void rebuild_for(int step, StepWork& work, OutOfCoreReport& report, double& lambda, bool every_step);
  StepPlan plan_step(int step, double lambda, int committed_here, bool every_step);
  // Each strategy's stages for one step or block (held_step.cpp, streamed_step.cpp,
  // block_step.cpp). `t0`: the step's start, moved on by the time spent building lists.
  PipelineStages held_stages(StepPlan& plan, StepWork& work);
  // A compensated held step's plain updates of every tile into held_updated_, and their halos.
  void held_plain_updates(StepPlan& plan, const StepWork& work);
  PipelineStages streamed_stages(StepPlan& plan, StepWork& work);
  PipelineStages block_stages(StepPlan& plan, StepWork& work, OutOfCoreReport& report, Clock::time_point& t0);
  // Runs the stages (with the previous step's pending writes and commit woven in), then what
  // every strategy does after: sample, scratch, collective writes, the step log.
  void run_step_pipeline(StepPlan& plan, StepWork& work, PipelineStages stages);
  // The step's state recorded and committed (or left pending); true when the run stops here.
  bool commit_step(StepPlan& plan, StepWork& work, OutOfCoreReport& report, int& committed_here);
  // The lagged step's items below `end` written and, once they all are, committed.
  void write_lagged(StepWork& work, std::size_t end);
  void finish_commit(StepWork& work);
  // finish_commit, then the positions in row order: before anything but the next step reads them.
  void finish_commit_timed(StepWork& work, OutOfCoreReport& report);
  // Bytes of the slots in flight (for account()).
  std::uint64_t step_slots_bytes(const StepWork& work) const;
  std::uint64_t block_slots_bytes(const StepWork& work) const;
  void hold_positions();
  void load_held(const h5::Dataset& source);
  // Tile t's halo in a buffer laid out as held_, from the tiles holding its points.
  void copy_halo(std::vector<Vec3>& buffer, std::size_t t) const;
  void release_positions();
  bool run_finish(OutOfCoreReport& report);
  std::optional<FinishLists> finish_lists(const Box& own, double halo, const LocalSet& local,
                                          const QuadricProjectionParams& q) const;
  // The k-long rows of the part's points `queries` (local indices; the gathered set in its
  // original order) that fit their own after the sharing projection, and the rows of the
  // gathered points they name that have no normal yet (has_normal); nullopt unless every
  // row is the in-core one (the halo must grow).
  std::optional<OwnFitRows> own_fit_rows(const Box& own, double halo, const LocalSet& local,
                                         std::span<const Index> queries, std::span<const char> has_normal,
                                         const QuadricProjectionParams& q) const;
  void finish_tile(std::size_t t, const QuadricProjectionParams& q, std::span<const Vec3> anchors,
                   std::vector<Vec3>& result);
  // One pass of the finish for `part` of tile t into `result` (the tile's rows); false when
  // the part with its halo would not fit the budget beside `held` bytes, `needed` then the
  // working bytes it would take at least.
  bool finish_part(std::size_t t, const TilePart& part, const QuadricProjectionParams& q,
                   std::span<const Vec3> anchors, std::vector<Vec3>& result, std::uint64_t held,
                   std::uint64_t& needed);
  std::size_t write_attributes(double lambda);
  void finish(std::size_t attributes_degenerate, double lambda);
  void account(std::uint64_t working);
  // Throws the BudgetError of a run that needs `total` bytes.
  [[noreturn]] void refuse(std::uint64_t total) const;
  std::uint64_t persistent_bytes() const {
    return cache_bytes_ + halo_bytes_ + bytes(halo_rows_) + (halo_scratch_ ? halo_scratch_->bytes() : 0) +
           (ring_scratch_ ? ring_scratch_->bytes() : 0) + bytes(block_lists_at_) + bytes(block_record_) + bytes(tiles_.offsets) + bytes(tiles_.bounds) + bytes(sample_rows_) +
           bytes(sample_neighbors_) + bytes(sample_counts_) + bytes(sample_local_) + bytes(gather_rows_) +
           bytes(gather_positions_) + held_bytes_;
  }
  void progress(const std::string& phase, std::uint64_t done, std::uint64_t total) const {
    if (options_.progress) options_.progress(phase, done, total);
  }
  h5::File& file() { return *file_; }
  const h5::File& file() const { return *file_; }
  int k() const { return params_.neighbors.k; }
  bool auto_lambda_on() const { return params_.flow.lambda == 0.0; }
  // SmoothParams::stop_lambda_ratio or stop_plateau applies (as in smooth(): anisotropic,
  // automatic lambda measured every step).
  bool stops_automatically() const {
    return params_.flow.flow == Flow::Anisotropic && auto_lambda_on() && params_.lambda_every_step &&
           (params_.stop_lambda_ratio > 0.0 || params_.stop_plateau > 0.0);
  }
  bool compensated() const { return params_.shrink_compensation > 0.0; }
  bool momentum_on() const { return has_momentum(params_); }
  // Whether `v` holds on any / on every rank (collective when there are several).
  bool on_any_rank(bool v) const { return ranks_->size() > 1 ? ranks_->sum(v ? 1 : 0) > 0 : v; }
  bool on_every_rank(bool v) const { return !on_any_rank(!v); }
  // Steps per temporal block: OutOfCoreOptions::temporal_block, 1 with momentum (a point's
  // last move is known only for the step after it).
  int temporal_block() const { return momentum_on() ? 1 : std::max(1, options_.temporal_block); }
  bool temporal_blocks() const { return temporal_block() > 1; }
  // Steps load a tile with the rings of its lists' closure (BlockSlot) rather than one halo:
  // temporal blocks, compensated steps unless the positions are held in memory (then a
  // compensated step is two passes over the held tiles, each with its one halo), and plain
  // streamed steps as blocks of one step (choose_step_blocks).
  bool blocks() const { return temporal_blocks() || (compensated() && !holding_) || step_blocks_; }
  // Whether plain steps that stream their positions and lists go through blocks of one step
  // (OutOfCoreOptions::step_blocks): once the lists and positions are known not to be kept in
  // memory, and only where the block scratch is made (prepare_block_lists).
  void choose_step_blocks();
  // Levels of a block of h steps (BlockSlot): h, or 2 h when compensated.
  int block_depth(int h) const { return compensated() ? 2 * h : h; }
  std::string current_source() const {
    return state_[kStepBuffer] == 0 ? step0_source()
                                    : positions_buffer(static_cast<int>((state_[kStepBuffer] - 1) % 2));
  }
  // Whether the current buffer holds each tile's rows in the order of its lists (kStepBuffer).
  bool source_in_list_order() const { return state_[kStepBuffer] >= 3; }
  // The buffer (0 or 1) the next step or block writes: never the one it reads.
  int target_buffer() const { return state_[kStepBuffer] > 0 && (state_[kStepBuffer] - 1) % 2 == 1 ? 0 : 1; }
  // Its kStepBuffer code once written, in row order or in list order.
  std::int64_t target_code(bool list_order) const { return target_buffer() + (list_order ? 3 : 1); }
  void to_row_order();
  // A block of depth h of tile t into `s`: its lists (from the block-lists scratch when it has
  // at least that depth, else built from the run file's lists), then its positions of `source`, the
  // rings' from buffer `ring_buffer` of the ring scratch when it is 0 or 1 (and the lists
  // came from the scratch). `listed`: the source holds the tile in its lists' order (only
  // with lists and rings from the scratch).
  void read_block(std::size_t t, int h, const h5::Dataset& source, BlockSlot& s, int ring_buffer = -1,
                  bool listed = false);
  // `morton`: the tile's points in Morton order (BlockSlot::order).
  void build_block_lists(std::size_t t, int h, BlockSlot& s, bool morton);
  std::uint64_t store_block_lists(const BlockSlot& s, std::uint64_t offset);
  // Tile t's record of the scratch into `s`, as a block of depth h (at most the scratch's:
  // the first h levels of its closure).
  void load_block_lists(std::size_t t, int h, BlockSlot& s);
  // The block-lists and ring scratch for blocks of depth d (single process, where they can be
  // made and fit in the budget; else blocks build their lists from the run file as before).
  void prepare_block_lists(int d);
  void release_block_lists();
  // Every scratch of the steps (halos, block lists, rings) dropped, to be made again when
  // wanted (after a rebuild; after the steps, for the room).
  void release_scratch();
  // Where the scratch files go: the output's directory.
  fs::path scratch_directory() const;
  // The buffer (0 or 1) of a halo or ring scratch that holds the current source's positions,
  // by the scratch's `holds` (per buffer, the dataset whose positions it holds; empty: none);
  // -1 when none does.
  int buffer_holding_source(const std::array<std::string, 2>& holds) const;
  // Tile u's points in the order the blocks give them to the ring scratch (BlockSlot::order).
  std::vector<Index> block_order(std::size_t u) const;
  // Every tile's positions of `source` into buffer b of the ring scratch.
  void fill_ring_scratch(const h5::Dataset& source, int b);
  // The room kept for the tiles in flight.
  std::uint64_t slots_room() const { return slots_ * (slot_estimate_ + slot_estimate_ / 2); }
  int block_length(int step) const;

  fs::path input_path_, output_;
  SmoothParams params_;
  OutOfCoreOptions options_;
  Ranks single_;
  Ranks* ranks_;
  bool shared_ = false;  // every rank has the file open (else only rank 0)
  // This rank's tiles [first_tile_, end_tile_).
  std::size_t first_tile_ = 0, end_tile_ = 0;
  std::uint64_t halo_points_ = 0;
  // Rank 0 holds the run file exclusively from before it opens it until the run ends.
  std::optional<io::FileLock> lock_;
  std::optional<h5::File> file_;
  TileTable tiles_;
  std::uint64_t n_ = 0;
  // Steps the run ends with: params_.steps, or fewer when the automatic stop ended it.
  int final_steps_ = -1;
  // The lambda that stopped the run (measured on its final positions), as smooth() reports it.
  double stop_lambda_ = 0.0;
  std::vector<std::int64_t> state_ = std::vector<std::int64_t>(kStateSize, 0);
  // Slots of the run file's state record (kLegacyStateSize in runs without the finish).
  std::size_t state_rows_ = kStateSize;
  double eps_ = 0.0;
  // The positions neighbourhoods are built from (the input's, the reference's or the current
  // step's), and the bounds of every tile's points in it (the tile table's for the input).
  std::string neighbor_source_ = layout::positions;  // kStartPositions once the run starts from them
  Box global_bounds_{};
  std::uint64_t max_tile_rows_ = 0;

  // The lambda sample: rows of the sampled points (in sample order), the local indices (into
  // gather_rows_) of each sample and of its neighbours, and the step-n positions of
  // gather_rows_.
  std::vector<std::uint64_t> sample_rows_;
  std::vector<Index> sample_local_;
  std::vector<Index> sample_neighbors_;
  std::vector<std::uint16_t> sample_counts_;
  std::vector<std::uint64_t> gather_rows_;
  std::vector<Vec3> gather_positions_;
  // Whether the sample is gathered as above (while it takes at most the room kept for it,
  // lambda_sample_room); else only sample_rows_ is kept, and each lambda reads the
  // sample's lists and positions from sample_source_ in pieces (sample_lambda_in_pieces).
  bool sample_gathered_ = true;
  std::string sample_source_;

  // Neighbour lists of every tile, kept while they fit in part of the budget.
  // Shared with the slots of the pipeline, so that dropping the cache never frees lists a tile
  // in flight is computing with.
  std::vector<std::shared_ptr<const TileNeighbors>> cache_;
  // Per tile: whether /run/neighbors/local holds its lists in local indices (written by this
  // process; 2: in Morton order, with kLocalOrder), and its halo rows.
  std::vector<char> local_written_;
  std::vector<std::vector<std::uint64_t>> halo_rows_;
  std::uint64_t halo_bytes_ = 0;
  // Streamed steps' halos (streamed_halos), and the dataset whose halos each buffer of it
  // holds (positions_buffer(b) as it now is; empty: none).
  std::unique_ptr<HaloScratch> halo_scratch_;
  std::array<std::string, 2> scratch_holds_{};
  bool scratch_refused_ = false;
  // Streamed blocks (temporal blocks, compensated steps): every tile's lists of a block of
  // depth block_lists_depth_ (BlockSlot) in a scratch file, from block_lists_at_[t - first
  // tile]; the positions of every tile's rings in a halo scratch of their own, and whether
  // buffer b of it holds those of positions_buffer(b).
  std::unique_ptr<ScratchFile> block_lists_;
  std::vector<std::uint64_t> block_lists_at_;
  int block_lists_depth_ = 0;
  std::vector<unsigned char> block_record_;
  std::unique_ptr<HaloScratch> ring_scratch_;
  // The positions each buffer of the ring scratch holds: the name of their dataset (empty: none).
  std::array<std::string, 2> ring_holds_{};
  bool blocks_refused_ = false;
  bool caching_ = true;
  bool ran_blocks_ = false;  // a step ran as blocks, whose lists the cache does not hold
  bool step_blocks_ = false;  // plain steps as blocks of one step (choose_step_blocks)
  // Whether the run file has kLocalOrder (tile lists in Morton order, see TileNeighbors).
  bool local_order_ = false;
  std::uint64_t cache_bytes_ = 0;
  std::uint64_t peak_ = 0;
  std::uint64_t max_working_ = 0;
  std::uint64_t largest_local_ = 0;
  std::uint64_t finish_tiles_in_parts_ = 0;
  // Tiles in flight in the step pipeline, and the bytes one of them may hold.
  std::uint64_t slots_ = 1;
  // The most tiles a step had in flight (all of them in a list-order step).
  std::uint64_t most_in_flight_ = 0;
  std::uint64_t slot_estimate_ = 0;
  // Positions kept in memory across steps (hold_positions): while every tile's lists are cached
  // and both fit in the budget, the steps read their source from here instead of the file (the
  // run file still gets every step, committed as before). held_[b]: per tile, its points in
  // the lists' order then its halo, from element held_base_[t]; held_[held_cur_] holds the
  // step's source (read from the file when holding starts, load_held).
  // held_halo_[t][j]: the element of held_ holding halo point j of tile t in its own tile.
  bool holding_ = false;
  int held_cur_ = 0;
  std::array<std::vector<Vec3>, 2> held_;
  // A compensated step's plain updates (euler_step), laid out as held_ (compensated only).
  std::vector<Vec3> held_updated_;
  std::vector<std::uint64_t> held_base_;
  std::vector<std::vector<std::uint64_t>> held_halo_;
  // held_slot_[g - my_first_row()]: where row g sits in its tile's lists (and in held_ after
  // held_base_). held_list_order_: every tile's lists have an order (TileNeighbors::order), and
  // the steps but the last (and those before a rebuild) write the buffers in it (kStepBuffer
  // 3, 4): no scattered copy into row order a step, only one when something else reads the
  // positions (the last step, or to_row_order after an automatic stop or on --resume).
  std::vector<Index> held_slot_;
  // In a single process with the automatic lambda of every step: held_sample_[i], the element
  // of held_ holding gather_rows_[i], so that a step's sample is gathered from the held buffer
  // after the step, in parallel, instead of row by row as each tile is written.
  std::vector<std::uint64_t> held_sample_;
  bool held_list_order_ = false;
  std::uint64_t held_bytes_ = 0;
  // Rows of positions and of neighbour lists read by the steps (their I/O volume).
  std::uint64_t rows_read_ = 0;
  std::uint64_t list_rows_read_ = 0;
};

template <class PositionOf>
void Run::gather_sample_rows(std::uint64_t begin, std::uint64_t rows, PositionOf&& position_of) {
  auto it = std::lower_bound(gather_rows_.begin(), gather_rows_.end(), begin);
  for (; it != gather_rows_.end() && *it < begin + rows; ++it)
    gather_positions_[static_cast<std::size_t>(it - gather_rows_.begin())] = position_of(*it - begin);
}

}  // namespace pointfair::tiles::detail
