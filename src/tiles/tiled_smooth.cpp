#include "pointfair/tiles/tiled_smooth.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>

#include "pointfair/nearest_points.hpp"
#include "pointfair/neighborhood_size.hpp"
#include "pointfair/parallel.hpp"
#include "pointfair/params_error.hpp"
#include "pointfair/quadric_projection.hpp"
#include "pointfair/shrink_compensation.hpp"
#include "pointfair/spatial_order.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/tiles/balance.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/container_reader.hpp"
#include "pointfair/tiles/pipeline.hpp"
#include "pointfair/tiles/ranks.hpp"
#include "pointfair/version.hpp"
#include "halo_scratch.hpp"
#include "scratch_file.hpp"
#include "row_map.hpp"

namespace pointfair::tiles {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Slots of /run/state, the commit record: one small contiguous dataset rewritten in place.
// kStepBuffer: where the positions of step kCompletedSteps are (0: the input; 1, 2:
// positions_0, positions_1 in row order; 3, 4: the same buffers with each tile's rows in the
// order of its lists, kLocalOrder, as the steps write them while positions are held in memory,
// see Run::to_row_order); a step or temporal block writes into the other buffer.
// kNeighborsStep: the step whose positions the stored neighbour lists were built from (0: the
// input or the reference; a rebuild at step s overwrites them in place and records s).
// kFinishPasses: quadric finish passes done (OutOfCoreOptions::quadric_finish); a pass writes
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
constexpr std::size_t kLegacyStateSize = 6;

// Rows read at a time when filtering whole tiles for halos.
constexpr std::uint64_t kScanBlock = 1u << 15;
// A computed distance is trusted to decide "inside the halo" only with this relative margin.
constexpr double kHaloMargin = 1e-9;

// SmoothOptions::neighbor_reference out of core: the reference's positions in row order.
constexpr const char* kReferencePositions = "/run/reference_positions";
// Per row of /run/neighbors/local: which tile row the list belongs to (see TileNeighbors).
// Absent from runs started by an older version: their lists stay in row order.
constexpr const char* kLocalOrder = "/run/neighbors/local_order";
// The lambda of an automatic stop (smooth()'s, measured on the final step's positions), kept
// with the first finish pass: a resumed finish no longer has those positions to measure.
constexpr const char* kStopLambda = "/run/finish_stop_lambda";

std::string positions_buffer(int parity) { return "/run/positions_" + std::to_string(parity); }

// Every parameter that changes the result, as one line: stored in the run and compared on
// --resume.
std::string parameters_key(const SmoothParams& p) {
  std::ostringstream s;
  s.precision(17);
  s << "k=" << p.neighbors.k << " eps=" << p.neighbors.eps << " eps_factor=" << p.neighbors.eps_auto_factor
    << " steps=" << p.steps << " rebuild=" << p.rebuild_interval << " lambda_every_step=" << p.lambda_every_step
    << " flow=" << static_cast<int>(p.flow.flow) << " cutoff=" << static_cast<int>(p.flow.cutoff)
    << " lambda=" << p.flow.lambda << " lambda_factor=" << p.flow.lambda_auto_factor << " tau=" << p.flow.tau
    << " constrain_normal=" << p.flow.constrain_normal << " feature_gated=" << p.flow.feature_gated
    << " features=" << static_cast<int>(p.flow.features.mode) << " quotient=" << p.flow.features.quotient
    << " feature_threshold=" << p.flow.features.threshold
    << " weights=" << static_cast<int>(p.flow.weingarten.weights)
    << " density_floor=" << p.flow.weingarten.density_floor
    << " cutoff_origin=" << static_cast<int>(p.flow.cutoff_origin)
    << " stop_lambda_ratio=" << p.stop_lambda_ratio
    << " normal=" << static_cast<int>(p.flow.normal_estimator) << " robust_seed=" << p.flow.robust.seed_neighbors
    << " robust_iterations=" << p.flow.robust.iterations << " robust_bound=" << p.flow.robust.inlier_bound;
  // Named only when on, so that runs started before these options existed still resume.
  if (p.stop_plateau != 0.0) s << " stop_plateau=" << p.stop_plateau;
  if (p.shrink_compensation != 0.0) s << " shrink_compensation=" << p.shrink_compensation;
  return s.str();
}

// Every parameter of the quadric finish, for the same line.
std::string finish_key(const QuadricProjectionParams& q) {
  std::ostringstream s;
  s.precision(17);
  s << "quadric_k=" << q.k << " quadric_normal_neighbors=" << q.normal_neighbors
    << " quadric_angle=" << q.normal_angle << " quadric_iterations=" << q.iterations
    << " quadric_bound=" << q.inlier_bound << " quadric_degree=" << q.degree << " quadric_passes=" << q.passes
    << " quadric_curvature_reach=" << q.curvature_reach << " quadric_min_k=" << q.min_k
    << " quadric_frame_seed=" << q.frame.seed_neighbors << " quadric_frame_iterations=" << q.frame.iterations
    << " quadric_frame_bound=" << q.frame.inlier_bound;
  return s.str();
}

// Empties a vector and gives its memory back (`v = {}` would keep the capacity: it assigns
// an empty initializer list).
template <class T>
void free_vector(std::vector<T>& v) {
  std::vector<T>().swap(v);
}

// Bytes held by a vector.
template <class T>
std::uint64_t bytes(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}

// A tile's points plus its halo, sorted by original index (for neighbourhood building).
struct LocalSet {
  std::vector<Vec3> positions;
  std::vector<std::uint64_t> rows;      // container rows
  std::vector<std::uint64_t> original;  // original indices
  std::vector<Index> queries;           // local indices of the tile's own points, in row order
  std::uint64_t bytes() const {
    return tiles::bytes(positions) + tiles::bytes(rows) + tiles::bytes(original) + tiles::bytes(queries);
  }
};

// The quadric finish's lists of one tile's gathered points (LocalSet, local indices): each
// tile point's fit (its k nearest; row r: the tile's row r), and the rows every normal those
// fits read is fitted to (a row for every gathered point, empty for those no fit reads).
struct FinishLists {
  Neighborhoods fits;
  Neighborhoods normals;
  std::uint64_t near_bytes = 0;  // what built the halo points' rows held
  std::uint64_t bytes() const {
    return tiles::bytes(fits.indices) + tiles::bytes(fits.counts) + tiles::bytes(normals.indices) +
           tiles::bytes(normals.counts) + near_bytes;
  }
};

// The neighbour lists of one tile in local indices: local index s < tile size is row
// tile_begin + order[s] (order empty: s itself), else halo_rows[s - tile size]. The order is
// the Morton order of the tile's points (spatial_order.hpp), as the in-core steps use: a
// point's neighbours sit near it in memory, which the input's order inside a tile (the
// import keeps it) does not give. Each list keeps its order, so no bit of a result changes.
struct TileNeighbors {
  Neighborhoods local;
  std::vector<std::uint64_t> halo_rows;
  std::vector<Index> order;
  std::uint64_t bytes() const {
    return tiles::bytes(local.indices) + tiles::bytes(local.counts) + tiles::bytes(halo_rows) + tiles::bytes(order);
  }
  // values[order[s]] = local[s] for the tile's rows (row order from local order).
  template <class T, class U>
  void to_rows(const std::vector<T>& local_values, std::vector<U>& values, std::size_t rows) const {
    if (values.size() < rows) values.resize(rows);
    parallel_for(rows, [&](std::size_t begin, std::size_t end) {
      for (std::size_t s = begin; s < end; ++s) values[order.empty() ? s : order[s]] = static_cast<U>(local_values[s]);
    }, 8192);
  }
  // positions[s] = by_row[order[s]] for the tile's rows (local order from row order).
  void to_local(const std::vector<Vec3>& by_row, std::vector<Vec3>& positions, std::size_t rows) const {
    parallel_for(rows, [&](std::size_t begin, std::size_t end) {
      for (std::size_t s = begin; s < end; ++s) positions[s] = by_row[order[s]];
    }, 8192);
  }
};

// One tile in flight of a temporal block of h steps: its points (levels 0) and the rings of
// its neighbour-list closure (level l + 1: the neighbours of levels <= l not already in them),
// d = h levels deep, in local indices ordered by level. Step j of the block moves the points of
// levels 0 .. h - j, each from the positions of step j - 1 of its neighbours (one level
// further out at most), so after h steps the tile's points hold exactly the in-core step.
// A compensated step (SmoothParams::shrink_compensation) needs the plain updates of a point's
// neighbours, which need their own neighbours: two rings a step, d = 2 h levels. Step j then
// takes the plain update of levels 0 .. d - 2 j + 1 and compensates levels 0 .. d - 2 j.
struct BlockSlot {
  std::size_t tile = 0;
  std::vector<std::size_t> level_end;      // end of level l in local indices, l = 0 .. h
  std::vector<Neighborhoods> lists;        // lists of levels 0 .. h - 1, local indices (built)
  // What compute() reads: each level's lists (in `lists`, or in `mapped`), and where they lie
  // one after the other (mapped), all levels as one (stride 0 otherwise).
  std::vector<NeighborhoodsView> views;
  NeighborhoodsView all;
  ScratchFile::Mapping mapped;             // the block-lists scratch's record of the tile
  std::vector<Vec3> cur, next;
  std::vector<Vec3> updated;               // plain updates of a compensated step
  std::vector<Index> ids;                  // 0, 1, 2, ...
  std::vector<std::size_t> degenerate;     // per step of the block, the tile's own points
  std::vector<std::uint64_t> rows;         // container row of each local point
  std::vector<std::uint64_t> sorted_rows;  // ring rows ascending, and their local indices
  std::vector<Index> sorted_local;
  RowMap ring_local;                       // the same, looked up by row
  std::vector<std::uint32_t> global;       // lists of a level in container rows, while reading
  std::vector<std::uint16_t> counts;
  std::vector<Vec3> scratch;
  // The tile's points in Morton order (blocks whose lists come from the block-lists scratch):
  // local point s < the tile's size is its row order[s] (empty: row s); `by_row` holds the
  // tile's positions in row order, read before the block and written after it.
  std::vector<Index> order;
  std::vector<Vec3> by_row;
  // A block whose source holds the tile in that order (written so by the previous block):
  // read straight into `cur`. One that writes it so: `cur` is the result, `by_row` unused.
  bool read_listed = false, write_listed = false;
  // bytes() as the writing thread last measured it, between the slot's compute stages: the
  // compute trades `cur` and `next`, so the slot's vectors are not read while it runs.
  std::uint64_t accounted = 0;

  std::uint64_t bytes() const {
    std::uint64_t b = tiles::bytes(level_end) + tiles::bytes(cur) + tiles::bytes(next) + tiles::bytes(updated) +
                      tiles::bytes(ids) +
                      tiles::bytes(degenerate) + tiles::bytes(rows) + tiles::bytes(sorted_rows) +
                      tiles::bytes(sorted_local) + tiles::bytes(global) + tiles::bytes(counts) + tiles::bytes(scratch) + ring_local.bytes() +
                      tiles::bytes(order) + tiles::bytes(by_row) + mapped.size() + tiles::bytes(views);
    for (const Neighborhoods& l : lists) b += tiles::bytes(l.indices) + tiles::bytes(l.counts);
    return b;
  }
  std::size_t points() const { return level_end.back(); }

  // `beta`: SmoothParams::shrink_compensation (0: plain steps); the block has d = h levels
  // of lists, or 2 h when compensated.
  void compute(const FlowParams& flow, double lambda, double beta) {
    const std::size_t rings = beta > 0.0 ? 2 : 1;
    const std::size_t d = views.size(), h = d / rings;
    const auto ids_of = [&](std::size_t l) {
      const std::size_t begin = l == 0 ? 0 : level_end[l - 1];
      return std::span<const Index>(ids.data() + begin, level_end[l] - begin);
    };
    const auto part = [&](std::vector<Vec3>& v, std::size_t l) {
      const std::size_t begin = l == 0 ? 0 : level_end[l - 1];
      return std::span<Vec3>(v.data() + begin, level_end[l] - begin);
    };
    if (beta > 0.0) updated.resize(cur.size());
    const std::size_t own = level_end[0];
    if (!order.empty() && !read_listed)
      parallel_for(own, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) cur[i] = by_row[order[i]];
      }, 8192);
    for (std::size_t j = 1; j <= h; ++j) {
      // The deepest level whose step-j positions are exact, and the deepest plain update.
      const std::size_t last = d - rings * j, reach = last + rings - 1;
      // An empty level (a tile without halo) is skipped: empty rows would mean "every point"
      // to the kernels.
      // The tile's own points (their degenerate count is the step's), then the rings: as one
      // range where their lists lie one after the other.
      std::vector<Vec3>& out = beta > 0.0 ? updated : next;
      degenerate[j - 1] = ids_of(0).empty() ? 0 : euler_step(cur, views[0], ids_of(0), flow, lambda, part(out, 0)).degenerate;
      if (all.stride != 0 && reach >= 1) {
        const std::size_t b = level_end[0], e = level_end[reach];
        if (e > b)
          euler_step(cur, all.rows(b, e - b), std::span<const Index>(ids.data() + b, e - b), flow, lambda,
                     std::span<Vec3>(out.data() + b, e - b));
      } else {
        for (std::size_t l = 1; l <= reach; ++l)
          if (!ids_of(l).empty()) euler_step(cur, views[l], ids_of(l), flow, lambda, part(out, l));
      }
      if (beta > 0.0)
        for (std::size_t l = 0; l <= last; ++l)
          if (!ids_of(l).empty())
            compensate_shrinkage(cur, std::span<const Vec3>(updated.data(), cur.size()), views[l], ids_of(l), beta,
                                 part(next, l));
      // Levels 0 .. last now hold step j in `next`; the later steps read no level beyond
      // `last` (they reach one level less each), so the buffers trade places.
      std::swap(cur, next);
    }
    if (!order.empty() && !write_listed)
      parallel_for(own, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) by_row[order[i]] = cur[i];
      }, 8192);
  }
  // The tile's positions after the block, in row order.
  const Vec3* tile_rows() const { return order.empty() || write_listed ? cur.data() : by_row.data(); }
};

class Run {
 public:
  Run(const fs::path& input, const fs::path& output, const SmoothParams& params, const OutOfCoreOptions& options)
      : input_path_(input), output_(output), params_(params), options_(options),
        ranks_(options.ranks != nullptr ? options.ranks : &single_) {}

  OutOfCoreReport run();

 private:
  void read_input_tables();
  void open_or_create();
  void create(const fs::path& partial);
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
  void load_reference();
  void measure_bounds();
  void rebuild_neighbors(int step);
  bool rebuild_due(int step) const {
    return params_.rebuild_interval > 0 && step > 0 && step % params_.rebuild_interval == 0;
  }
  double resolve_eps_tiled();
  int resolve_k_tiled();
  // Calls measure(sample, indices, squared distances, local positions) for every point of this
  // rank's tiles whose original index is a multiple of `stride`, with its `want` nearest points
  // (itself included) among its tile and a halo grown until it holds them all. Concurrent.
  template <class Measure>
  void for_each_sample_knn(std::uint64_t stride, int want, const char* stage, Measure&& measure);
  double first_halo(std::size_t t) const;
  double knn_first_halo(std::size_t t, int neighbors) const;
  bool covers_all(std::size_t t, double halo) const;
  LocalSet gather_local(std::size_t t, double halo) const;
  void prepare_lambda_sample();
  double sample_lambda() const;
  void load_sample_positions(const h5::Dataset& positions);
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
  bool run_steps(OutOfCoreReport& report);
  void hold_positions();
  void load_held(const h5::Dataset& source);
  // Tile t's halo in a buffer laid out as held_, from the tiles holding its points.
  void copy_halo(std::vector<Vec3>& buffer, std::size_t t) const;
  void release_positions();
  bool run_finish(OutOfCoreReport& report);
  std::optional<FinishLists> finish_lists(std::size_t t, double halo, const LocalSet& local,
                                          const QuadricProjectionParams& q) const;
  void finish_tile(std::size_t t, const QuadricProjectionParams& q, std::vector<Vec3>& result);
  std::size_t write_attributes(double lambda);
  void finish(std::size_t attributes_degenerate, double lambda);
  void account(std::uint64_t working);
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
  // Whether `v` holds on any / on every rank (collective when there are several).
  bool on_any_rank(bool v) const { return ranks_->size() > 1 ? ranks_->sum(v ? 1 : 0) > 0 : v; }
  bool on_every_rank(bool v) const { return !on_any_rank(!v); }
  bool temporal_blocks() const { return options_.temporal_block > 1; }
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
    return state_[kStepBuffer] == 0 ? std::string(layout::positions)
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
  std::string neighbor_source_ = layout::positions;
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

void Run::account(std::uint64_t working) {
  max_working_ = std::max(max_working_, working);
  const std::uint64_t total = persistent_bytes() + working;
  peak_ = std::max(peak_, total);
  if (total > options_.memory_budget)
    throw BudgetError("the memory budget of " + size_text(options_.memory_budget, false) +
                          " is too small for the tiles of " + input_path_.string() + " (the run needs " +
                          size_text(total, true) +
                          "): give a larger budget, or import the input again with a smaller budget (smaller tiles)",
                      options_.memory_budget, total);
}

void Run::commit_state(const std::vector<std::int64_t>& record) {
  // Everything written before this point (by every rank) reaches the file first; then rank 0
  // overwrites the small state record in place (its storage was allocated when the file was
  // created, so the write changes no metadata).
  file().flush();
  if (shared_) ranks_->barrier();
  if (ranks_->rank() == 0) file().dataset(layout::run_state).write_rows(0, state_rows_, record.data());
  file().flush();
}

void Run::share() {
  // Rank 0 created or checked the file alone; now every rank opens it for parallel I/O.
  if (ranks_->size() > 1) {
    file_.reset();
    ranks_->barrier();
    file_.emplace(ranks_->open_shared(partial_name(output_)));
    state_ = file().dataset(layout::run_state).read_all<std::int64_t>();
    state_rows_ = state_.size();
    state_.resize(kStateSize, 0);
  }
  shared_ = true;
}

void Run::release() {
  // The end of the parallel part: rank 0 alone finishes the file (metadata changes).
  if (ranks_->size() > 1) {
    file_.reset();
    ranks_->barrier();
    if (ranks_->rank() == 0) file_.emplace(h5::File::open(partial_name(output_), true));
  }
  shared_ = false;
}

// Collective writes: every rank writes as many tiles as the rank with the most non-empty
// tiles, the missing ones as empty selections (h5::Transfer::Collective).
std::uint64_t Run::my_tiles() const {
  std::uint64_t mine = 0;
  for (std::size_t t = first_tile_; t < end_tile_; ++t) mine += tiles_.rows(t) > 0;
  return mine;
}

std::uint64_t Run::tiles_to_write() const {
  std::array<std::uint64_t, 1> most = {my_tiles()};
  ranks_->max(most);
  return most[0];
}

void Run::balance(bool with_halo) {
  std::vector<std::uint64_t> costs(tiles_.size());
  for (std::size_t t = 0; t < tiles_.size(); ++t) costs[t] = tiles_.rows(t);
  // A run started before the halo counts were recorded balances by points alone.
  if (with_halo && !tiles_.bounds.empty() && file().exists(layout::neighbor_halo_counts)) {
    const auto halo = file().dataset(layout::neighbor_halo_counts).read_all<std::uint64_t>();
    halo_points_ = 0;
    for (std::size_t t = 0; t < costs.size() && t < halo.size(); ++t) {
      costs[t] += halo[t];
      halo_points_ += halo[t];
    }
  }
  const std::vector<std::size_t> b = balance_ranges(costs, ranks_->size());
  first_tile_ = b[static_cast<std::size_t>(ranks_->rank())];
  end_tile_ = b[static_cast<std::size_t>(ranks_->rank()) + 1];
}

void Run::create(const fs::path& partial) {
  const h5::File in = h5::File::open(input_path_, false);
  file_.emplace(h5::File::create(partial));
  h5::File& f = file();
  f.create_group(layout::run);
  h5::DatasetOptions early;
  early.allocate_early = true;
  state_rows_ = options_.quadric_finish ? std::size_t{kStateSize} : kLegacyStateSize;
  f.create_dataset(layout::run_state, h5::Type::Int64, state_rows_, 0, early)
      .write_rows(0, state_rows_, state_.data());
  for (const char* name : {"pointfair_format", "source_name"})
    f.set_attribute("/", name, in.string_attribute("/", name));
  for (const char* name : {"format_version", "source_size_bytes", "point_count", "tile_count"})
    f.set_attribute("/", name, in.int_attribute("/", name));
  f.set_attribute("/", "tool_version", version());
  f.copy_from(in, layout::points, layout::points);
  f.copy_from(in, layout::tiles, layout::tiles);

  f.set_attribute(layout::run, "parameters", key());
  f.set_attribute(layout::run, "input_name", input_path_.filename().string());
  f.set_attribute(layout::run, "input_size_bytes", static_cast<std::int64_t>(fs::file_size(input_path_)));
  f.set_attribute(layout::run, "tool_version", version());
  f.set_attribute(layout::run, "k", static_cast<std::int64_t>(params_.neighbors.k));
  f.set_attribute(layout::run, "eps_requested", params_.neighbors.eps);
  f.set_attribute(layout::run, "eps_factor", params_.neighbors.eps_auto_factor);
  f.set_attribute(layout::run, "steps", static_cast<std::int64_t>(params_.steps));
  f.set_attribute(layout::run, "tau", params_.flow.tau);
  f.set_attribute(layout::run, "flow", params_.flow.flow == Flow::Isotropic ? "iso" : "aniso");
  f.set_attribute(layout::run, "cutoff", params_.flow.cutoff == Cutoff::Sharp ? "sharp" : "continuous");
  f.set_attribute(layout::run, "lambda_requested", params_.flow.lambda);
  f.set_attribute(layout::run, "lambda_factor", params_.flow.lambda_auto_factor);
  f.set_attribute(layout::run, "lambda_every_step", static_cast<std::int64_t>(params_.lambda_every_step));
  f.set_attribute(layout::run, "constrain_normal", static_cast<std::int64_t>(params_.flow.constrain_normal));
  f.set_attribute(layout::run, "feature_gated", static_cast<std::int64_t>(params_.flow.feature_gated));
  f.set_attribute(layout::run, "features",
                  params_.flow.features.mode == FeatureMode::None           ? "none"
                  : params_.flow.features.mode == FeatureMode::EdgeQuotient ? "quotient"
                                                                            : "maxcurv");
  f.set_attribute(layout::run, "edge_quotient", params_.flow.features.quotient);
  f.set_attribute(layout::run, "feature_threshold", params_.flow.features.threshold);
  f.set_attribute(layout::run, "weights",
                  params_.flow.weingarten.weights == AngularWeights::Paper ? "paper" : "uniform");
  f.set_attribute(layout::run, "density_floor", params_.flow.weingarten.density_floor);
  f.set_attribute(layout::run, "normal",
                  params_.flow.normal_estimator == NormalEstimator::Robust ? "robust" : "pca");

  f.create_dataset(layout::run_eps, h5::Type::Float64, 1, 0, early);
  f.create_dataset(layout::run_step_log, h5::Type::Float64, static_cast<std::uint64_t>(std::max(1, params_.steps)),
                   2, early);
  h5::DatasetOptions rows = early;
  rows.chunk_rows = std::min<std::uint64_t>(65536, std::max<std::uint64_t>(n_, 1));
  f.create_group("/run/neighbors");
  f.create_dataset(layout::neighbor_rows, h5::Type::UInt32, n_, static_cast<std::uint64_t>(k()), rows);
  f.create_dataset(layout::neighbor_counts, h5::Type::UInt16, n_, 0, rows);
  f.create_dataset(layout::neighbor_local, h5::Type::UInt32, n_, static_cast<std::uint64_t>(k()), rows);
  f.create_dataset(kLocalOrder, h5::Type::UInt32, n_, 0, rows);
  f.create_dataset(layout::neighbor_halo_counts, h5::Type::UInt64, std::max<std::uint64_t>(tiles_.size(), 1), 0,
                   early);
  f.create_dataset(positions_buffer(0), h5::Type::Float64, n_, 3, rows);
  f.create_dataset(positions_buffer(1), h5::Type::Float64, n_, 3, rows);
  if (!options_.neighbor_reference.empty()) {
    f.create_dataset(kReferencePositions, h5::Type::Float64, n_, 3, rows);
    f.set_attribute(layout::run, "neighbors_from", options_.neighbor_reference.filename().string());
  }
  if (options_.attributes) {
    f.create_group(layout::run_attributes);
    const std::string a = layout::run_attributes;
    for (const char* name : {"normal", "d1", "d2"}) f.create_dataset(a + "/" + name, h5::Type::Float64, n_, 3, rows);
    for (const char* name : {"k1", "k2", "mean_curvature", "laplacian_norm"})
      f.create_dataset(a + "/" + name, h5::Type::Float64, n_, 0, rows);
    f.create_dataset(a + "/feature_class", h5::Type::UInt8, n_, 0, rows);
  }
  if (options_.quadric_finish) {
    f.create_dataset(kStopLambda, h5::Type::Float64, 1, 0, early);
    const QuadricProjectionParams& q = *options_.quadric_finish;
    f.set_attribute(layout::run, "quadric_k", static_cast<std::int64_t>(q.k));
    f.set_attribute(layout::run, "quadric_angle", q.normal_angle);
    f.set_attribute(layout::run, "quadric_degree", static_cast<std::int64_t>(q.degree));
    f.set_attribute(layout::run, "quadric_passes", static_cast<std::int64_t>(q.passes));
  }
  state_.assign(kStateSize, 0);
  state_[kSetupDone] = 1;
  commit_state();
}

void Run::read_input_tables() {
  {
    const h5::File in = h5::File::open(input_path_, false);
    tiles_ = read_tile_table(in);
    n_ = point_count(in);
  }
  require(n_ < std::numeric_limits<Index>::max(), "a run holds fewer than 2^32-1 points");
  for (std::size_t t = 0; t < tiles_.size(); ++t) max_tile_rows_ = std::max(max_tile_rows_, tiles_.rows(t));
  constexpr double inf = std::numeric_limits<double>::infinity();
  global_bounds_ = {inf, inf, inf, -inf, -inf, -inf};
  for (const Box& b : tiles_.bounds)
    for (std::size_t c = 0; c < 3; ++c) {
      global_bounds_[c] = std::min(global_bounds_[c], b[c]);
      global_bounds_[c + 3] = std::max(global_bounds_[c + 3], b[c + 3]);
    }
}

void Run::open_or_create() {
  if (ranks_->rank() != 0) return;  // the others open the file in share()

  const fs::path partial = partial_name(output_);
  std::error_code ec;
  if (fs::exists(partial, ec)) {
    if (!options_.resume)
      throw io::IoError(partial.string() +
                        ": an interrupted run is in the way: pass --resume to continue it, or remove the file");
    bool usable = false;
    try {
      file_.emplace(h5::File::open(partial, true));
      if (file().exists(layout::run_state)) {
        const auto st = file().dataset(layout::run_state).read_all<std::int64_t>();
        if ((st.size() == kStateSize || st.size() == kLegacyStateSize) && st[kSetupDone] == 1) {
          state_ = st;
          state_rows_ = st.size();
          state_.resize(kStateSize, 0);
          usable = true;
        }
      }
    } catch (const io::IoError&) {
      usable = false;  // killed while it was being created: start again
    }
    if (usable) {
      const std::string stored = file().string_attribute(layout::run, "parameters");
      if (stored != key())
        throw ParamError(partial.string() + " was started with other parameters (" + stored +
                         "); run with those, or remove the file");
      if (point_count(file()) != n_)
        throw io::IoError(partial.string() + ": the interrupted run belongs to another input");
      return;
    }
    file_.reset();
    fs::remove(partial, ec);
  }
  create(partial);
}

// ---- neighbourhoods ---------------------------------------------------------------------------

bool Run::covers_all(std::size_t t, double halo) const {
  const Box& b = tiles_.bounds[t];
  for (std::size_t c = 0; c < 3; ++c)
    if (b[c] - halo > global_bounds_[c] || b[c + 3] + halo < global_bounds_[c + 3]) return false;
  return true;
}

double Run::first_halo(std::size_t t) const {
  if (std::isfinite(eps_) && eps_ > 0.0) return eps_ * (1.0 + 1e-6);
  return knn_first_halo(t, k());
}

double Run::knn_first_halo(std::size_t t, int neighbors) const {
  // Unbounded eps: start from the spacing a surface patch of the tile's size would have,
  // and grow until every (k+1)-th neighbour lies inside the halo.
  const Box& b = tiles_.bounds[t];
  const double side = std::max({b[3] - b[0], b[4] - b[1], b[5] - b[2], 0.0});
  const double diag = std::hypot(global_bounds_[3] - global_bounds_[0], global_bounds_[4] - global_bounds_[1],
                                 global_bounds_[5] - global_bounds_[2]);
  const double rows = static_cast<double>(std::max<std::uint64_t>(1, tiles_.rows(t)));
  return std::max(2.0 * side * std::sqrt((neighbors + 1.0) / rows), 1e-12 * (1.0 + diag));
}

LocalSet Run::gather_local(std::size_t t, double halo) const {
  const h5::Dataset pos = file().dataset(neighbor_source_);
  const h5::Dataset orig = file().dataset(layout::original_index);
  const Box& own = tiles_.bounds[t];
  Box grown = own;
  for (std::size_t c = 0; c < 3; ++c) {
    grown[c] -= halo;
    grown[c + 3] += halo;
  }
  struct Entry {
    std::uint64_t original, row;
    Vec3 p;
  };
  std::vector<Entry> entries;
  std::vector<double> xyz;
  std::vector<std::uint64_t> index;
  for (std::size_t u = 0; u < tiles_.size(); ++u) {
    if (tiles_.rows(u) == 0 || (u != t && !intersects(own, halo, tiles_.bounds[u]))) continue;
    for (std::uint64_t first = tiles_.offsets[u]; first < tiles_.offsets[u + 1]; first += kScanBlock) {
      const std::uint64_t count = std::min(kScanBlock, tiles_.offsets[u + 1] - first);
      xyz.resize(3 * count);
      index.resize(count);
      pos.read_rows(first, count, xyz.data());
      orig.read_rows(first, count, index.data());
      for (std::uint64_t r = 0; r < count; ++r) {
        const Vec3 p(xyz[3 * r], xyz[3 * r + 1], xyz[3 * r + 2]);
        if (!p.allFinite())
          file().fail(neighbor_source_, "row " + std::to_string(first + r) + " has a non-finite coordinate");
        bool inside = u == t;
        if (!inside) {
          inside = true;
          for (std::size_t c = 0; c < 3 && inside; ++c)
            inside = p[static_cast<Eigen::Index>(c)] >= grown[c] && p[static_cast<Eigen::Index>(c)] <= grown[c + 3];
        }
        if (inside) entries.push_back({index[r], first + r, p});
      }
    }
  }
  // Local indices ascending with the original index: the tie rule of the canonical order.
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.original < b.original; });
  LocalSet s;
  s.positions.reserve(entries.size());
  s.rows.reserve(entries.size());
  s.original.reserve(entries.size());
  s.queries.assign(tiles_.rows(t), 0);
  const std::uint64_t begin = tiles_.offsets[t], end = tiles_.offsets[t + 1];
  for (std::size_t i = 0; i < entries.size(); ++i) {
    s.positions.push_back(entries[i].p);
    s.rows.push_back(entries[i].row);
    s.original.push_back(entries[i].original);
    if (entries[i].row >= begin && entries[i].row < end) s.queries[entries[i].row - begin] = static_cast<Index>(i);
  }
  return s;
}

template <class Measure>
void Run::for_each_sample_knn(std::uint64_t stride, int want, const char* stage, Measure&& measure) {
  const h5::Dataset orig = file().dataset(layout::original_index);
  std::vector<std::uint64_t> index;
  const double saved_eps = eps_;
  eps_ = std::numeric_limits<double>::infinity();  // first_halo: grow from the tile's spacing
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t rows = tiles_.rows(t);
    if (rows == 0) continue;
    index.resize(rows);
    orig.read_rows(tiles_.offsets[t], rows, index.data());
    std::vector<std::pair<std::uint64_t, std::uint64_t>> mine;  // (sample, row in tile)
    for (std::uint64_t r = 0; r < rows; ++r)
      if (index[r] % stride == 0) mine.emplace_back(index[r] / stride, r);
    if (mine.empty()) continue;
    for (double halo = first_halo(t);; halo *= 2.0) {
      const LocalSet local = gather_local(t, halo);
      std::vector<Index> queries(mine.size());
      for (std::size_t i = 0; i < mine.size(); ++i) queries[i] = local.queries[mine[i].second];
      const NearestPoints near = nearest_points(local.positions, queries, want);
      // The cell grid held about 48 bytes a point while it searched.
      account(local.bytes() + local.positions.size() * 48 + bytes(queries) + bytes(near.indices) +
              bytes(near.distances2) + bytes(near.counts));
      const bool all = covers_all(t, halo);
      std::atomic<bool> ok{true};
      parallel_for(mine.size(), [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          const std::span<const Index> idx = near.indices_of(i);
          const std::span<const double> d2 = near.distances2_of(i);
          const int found = near.counts[i];
          // Settled when the halo holds all `want` points: the farthest lies inside it.
          if (!all && (found < want || !(std::sqrt(d2[static_cast<std::size_t>(found - 1)]) < halo * (1.0 - kHaloMargin)))) {
            ok = false;
            continue;
          }
          measure(mine[i].first, idx, d2, local.positions);
        }
      }, 64);
      if (ok) break;
    }
    progress(stage, t + 1 - first_tile_, end_tile_ - first_tile_);
  }
  eps_ = saved_eps;
}

double Run::resolve_eps_tiled() {
  NeighborParams np = params_.neighbors;
  np.validate();
  if (np.eps > 0.0) return np.eps;
  if (n_ < 2) return std::numeric_limits<double>::infinity();
  // The in-core resolve_eps: median distance to the (k+1)-th nearest point (the point itself
  // included) over the points with original index s * stride.
  const std::uint64_t stride = std::max<std::uint64_t>(1, n_ / 65536);
  const std::uint64_t samples = (n_ + stride - 1) / stride;
  const int want = static_cast<int>(std::min<std::uint64_t>(static_cast<std::uint64_t>(k()) + 1, n_));
  std::vector<double> kth(samples, 0.0);
  for_each_sample_knn(stride, want, "eps",
                      [&](std::uint64_t sample, std::span<const Index>, std::span<const double> d2,
                          std::span<const Vec3>) { kth[sample] = d2.empty() ? 0.0 : std::sqrt(d2.back()); });
  ranks_->max(kth);  // each sample was measured by the rank of its tile, 0 elsewhere
  auto mid = kth.begin() + static_cast<std::ptrdiff_t>(samples / 2);
  std::nth_element(kth.begin(), mid, kth.end());
  const double spacing = *mid;
  if (!(spacing > 0.0)) return std::numeric_limits<double>::infinity();
  return np.eps_auto_factor * spacing;
}

int Run::resolve_k_tiled() {
  // automatic_k(): the noise ratio of the points with original index s * stride, each over its
  // kNoiseProbePoints nearest points, found in the tile and a halo that holds them all.
  const std::uint64_t stride = noise_sample_stride(n_);
  const std::uint64_t samples = (n_ + stride - 1) / stride;
  const int want = static_cast<int>(std::min<std::uint64_t>(kNoiseProbePoints, n_));
  // -1: not this rank's sample; -0.5: measured, not usable (NaN, which a max would not carry).
  std::vector<double> ratios(samples, -1.0);
  for_each_sample_knn(stride, want, "k",
                      [&](std::uint64_t sample, std::span<const Index> idx, std::span<const double> d2,
                          std::span<const Vec3> positions) {
                        std::vector<ProbePoint> probe;
                        probe.reserve(idx.size());
                        for (std::size_t j = 0; j < idx.size(); ++j) probe.push_back({d2[j], positions[idx[j]]});
                        const double g = noise_ratio(probe, probe.size() == n_);
                        ratios[sample] = std::isfinite(g) ? g : -0.5;
                      });
  ranks_->max(ratios);  // each sample was measured by the rank of its tile
  for (double& g : ratios)
    if (g < 0.0) g = std::numeric_limits<double>::quiet_NaN();
  return k_for_noise_ratio(cloud_noise_ratio(ratios));
}

void Run::build_neighbors(int step) {
  eps_ = resolve_eps_tiled();
  h5::Dataset rows_ds = file().dataset(layout::neighbor_rows);
  h5::Dataset counts_ds = file().dataset(layout::neighbor_counts);
  const std::size_t stride = static_cast<std::size_t>(k());
  h5::Dataset halo_ds = file().dataset(layout::neighbor_halo_counts);
  std::vector<std::uint32_t> out, outside;
  const std::uint64_t writes = tiles_to_write();
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t rows = tiles_.rows(t);
    if (rows == 0) continue;
    for (double halo = first_halo(t);; halo *= 2.0) {
      LocalSet local = gather_local(t, halo);
      const Neighborhoods nb = build_neighborhoods(local.positions, local.queries, k(), eps_);
      // Exact when the halo holds every point within eps, or, for a larger eps, when every
      // point's (k+1)-th nearest point lies inside the halo.
      bool ok = std::isfinite(eps_) || covers_all(t, halo);
      if (!ok) {
        ok = true;
        for (std::size_t r = 0; r < nb.size() && ok; ++r) {
          if (nb.counts[r] < k()) {
            ok = false;
            break;
          }
          const Vec3& q = local.positions[local.queries[r]];
          const Vec3& last = local.positions[nb.indices[r * stride + stride - 1]];
          ok = (last - q).norm() < halo * (1.0 - kHaloMargin);
        }
      }
      if (!ok) continue;
      largest_local_ = std::max<std::uint64_t>(largest_local_, local.positions.size());
      out.resize(rows * stride);
      for (std::size_t r = 0; r < nb.size(); ++r)
        for (std::size_t j = 0; j < stride; ++j)
          out[r * stride + j] = j < nb.counts[r] ? static_cast<std::uint32_t>(local.rows[nb.indices[r * stride + j]]) : 0u;
      account(local.bytes() + local.positions.size() * 16 + bytes(nb.indices) + bytes(nb.counts) + bytes(out));
      rows_ds.write_rows(tiles_.offsets[t], rows, out.data(), h5::Transfer::Collective);
      counts_ds.write_rows(tiles_.offsets[t], rows, nb.counts.data(), h5::Transfer::Collective);
      // The halo a step reads: the distinct neighbours outside the tile (balances the steps).
      outside.clear();
      for (std::size_t r = 0; r < nb.size(); ++r)
        for (std::size_t j = 0; j < nb.counts[r]; ++j) {
          const std::uint32_t g = out[r * stride + j];
          if (g < tiles_.offsets[t] || g >= tiles_.offsets[t + 1]) outside.push_back(g);
        }
      std::sort(outside.begin(), outside.end());
      const std::uint64_t halo_count =
          static_cast<std::uint64_t>(std::unique(outside.begin(), outside.end()) - outside.begin());
      halo_ds.write_rows(t, 1, &halo_count, h5::Transfer::Collective);
      break;
    }
    progress("neighbors", t + 1 - first_tile_, end_tile_ - first_tile_);
  }
  for (std::uint64_t w = my_tiles(); w < writes; ++w) {
    rows_ds.write_rows<std::uint32_t>(0, 0, nullptr, h5::Transfer::Collective);
    counts_ds.write_rows<std::uint16_t>(0, 0, nullptr, h5::Transfer::Collective);
    halo_ds.write_rows<std::uint64_t>(0, 0, nullptr, h5::Transfer::Collective);
  }
  if (ranks_->rank() == 0) file().dataset(layout::run_eps).write_rows(0, 1, &eps_);
  state_[kNeighborsDone] = 1;
  state_[kNeighborsStep] = step;
  commit_state();
}

std::string Run::key() const {
  std::string k = parameters_key(params_);
  // Named only when on, so that runs without it started before it existed still resume.
  if (options_.quadric_finish) k += " " + finish_key(*options_.quadric_finish);
  if (!options_.neighbor_reference.empty()) {
    std::error_code ec;
    const auto size = fs::file_size(options_.neighbor_reference, ec);
    k += " neighbors_from=" + options_.neighbor_reference.filename().string() + ":" +
         std::to_string(ec ? 0 : size);
  }
  return k;
}

void Run::load_reference() {
  // The reference lists its points in the input's original order; rows hold them in tile
  // order. In passes over blocks of original indices that fit in an eighth of the budget: read the
  // block from the reference (streamed from its start), then put each of this rank's rows
  // whose original index falls in it.
  const fs::path& path = options_.neighbor_reference;
  const auto open = [&]() -> std::unique_ptr<io::PointChunkReader> {
    std::string e = path.extension().string();
    for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (e == ".h5" || e == ".hdf5") return std::make_unique<ContainerChunkReader>(path);
    return io::open_point_reader(path);
  };
  const h5::Dataset orig = file().dataset(layout::original_index);
  h5::Dataset target = file().dataset(kReferencePositions);
  constexpr std::size_t kChunk = 1u << 14;
  const std::uint64_t block = std::max<std::uint64_t>(1024, options_.memory_budget / 8 / sizeof(Vec3));
  std::vector<Vec3> values, rows;
  std::vector<std::uint64_t> index;
  io::PointTable chunk;
  for (std::uint64_t a = 0; a < std::max<std::uint64_t>(n_, 1); a += block) {
    const std::uint64_t b = std::min(n_, a + block);
    values.assign(b - a, Vec3::Zero());
    const auto reader = open();
    std::uint64_t at = 0;
    // The first pass reads the whole reference, to check its size.
    while (a == 0 || at < b) {
      const std::size_t got = reader->read(chunk, kChunk);
      if (got == 0) break;
      for (std::size_t i = 0; i < got; ++i)
        if (at + i >= a && at + i < b) values[at + i - a] = chunk.positions[i];
      at += got;
      account(bytes(values) + bytes(chunk.positions) + chunk.attributes.size() * kChunk * sizeof(double));
    }
    if (a == 0 && at != n_)
      throw ParamError("the neighbour reference " + path.string() + " has " + std::to_string(at) +
                       " points, the input " + std::to_string(n_));
    for (std::uint64_t first = my_first_row(); first < my_end_row(); first += kScanBlock) {
      const std::uint64_t count = std::min(kScanBlock, my_end_row() - first);
      index.resize(count);
      orig.read_rows(first, count, index.data());
      const bool all = std::all_of(index.begin(), index.end(), [&](std::uint64_t o) { return o >= a && o < b; });
      const bool any = all || std::any_of(index.begin(), index.end(), [&](std::uint64_t o) { return o >= a && o < b; });
      if (!any) continue;
      rows.resize(count);
      if (!all) target.read_rows(first, count, rows.data()->data());
      for (std::uint64_t r = 0; r < count; ++r)
        if (index[r] >= a && index[r] < b) rows[r] = values[index[r] - a];
      target.write_rows(first, count, rows.data()->data());
    }
  }
  free_vector(values);
}

void Run::measure_bounds() {
  // Points move: the halo of a rebuild needs the bounds of every tile's current points. Each
  // rank measures its own tiles; the maximum of (-min, max) over the ranks is every tile's.
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::vector<double> extent(6 * tiles_.size(), -inf);
  const h5::Dataset pos = file().dataset(neighbor_source_);
  std::vector<Vec3> block;
  for (std::size_t t = first_tile_; t < end_tile_; ++t)
    for (std::uint64_t first = tiles_.offsets[t]; first < tiles_.offsets[t + 1]; first += kScanBlock) {
      const std::uint64_t count = std::min(kScanBlock, tiles_.offsets[t + 1] - first);
      block.resize(count);
      pos.read_rows(first, count, block.data()->data());
      for (const Vec3& p : block)
        for (Eigen::Index c = 0; c < 3; ++c) {
          const std::size_t i = 6 * t + static_cast<std::size_t>(c);
          extent[i] = std::max(extent[i], -p[c]);
          extent[i + 3] = std::max(extent[i + 3], p[c]);
        }
    }
  ranks_->max(extent);
  global_bounds_ = {inf, inf, inf, -inf, -inf, -inf};
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    if (tiles_.rows(t) == 0) continue;
    for (std::size_t c = 0; c < 3; ++c) {
      tiles_.bounds[t][c] = -extent[6 * t + c];
      tiles_.bounds[t][c + 3] = extent[6 * t + c + 3];
      global_bounds_[c] = std::min(global_bounds_[c], tiles_.bounds[t][c]);
      global_bounds_[c + 3] = std::max(global_bounds_[c + 3], tiles_.bounds[t][c + 3]);
    }
  }
}

void Run::rebuild_neighbors(int step) {
  // smooth()'s rebuild: eps resolved again and the lists built from the step's positions,
  // over the same tiles with a geometric halo around their current bounds. The halo scratch
  // is of the old halos (made again for the new ones by the next streamed step).
  release_scratch();
  neighbor_source_ = current_source();
  measure_bounds();
  build_neighbors(step);
  // The lists in memory and in tile-local indices are the old ones, and so are the halos of
  // the positions held in memory.
  release_positions();
  cache_.assign(tiles_.size(), {});
  cache_bytes_ = 0;
  caching_ = true;
  local_written_.assign(tiles_.size(), 0);
  halo_rows_.assign(tiles_.size(), {});
  halo_bytes_ = 0;
  if (auto_lambda_on()) {
    prepare_lambda_sample();
    load_sample_positions(file().dataset(neighbor_source_));
  }
}

// ---- the lambda sample ------------------------------------------------------------------------

void Run::prepare_lambda_sample() {
  if (n_ == 0) return;
  // The in-core auto_lambda: the points with original index s * stride, stride = n / 8192.
  const std::uint64_t stride = std::max<std::uint64_t>(1, n_ / 8192);
  const std::uint64_t samples = (n_ + stride - 1) / stride;
  sample_rows_.assign(samples, 0);
  const h5::Dataset orig = file().dataset(layout::original_index);
  std::vector<std::uint64_t> index;
  // Each rank finds the samples among its rows (0 elsewhere); the maximum over the ranks is
  // every sample's row.
  for (std::uint64_t first = my_first_row(); first < my_end_row(); first += kScanBlock) {
    const std::uint64_t count = std::min(kScanBlock, my_end_row() - first);
    index.resize(count);
    orig.read_rows(first, count, index.data());
    for (std::uint64_t r = 0; r < count; ++r)
      if (index[r] % stride == 0) sample_rows_[index[r] / stride] = first + r;
  }
  ranks_->max(sample_rows_);
  std::vector<std::uint64_t> sorted = sample_rows_;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t kk = static_cast<std::size_t>(k());
  std::vector<std::uint32_t> lists(sorted.size() * kk);
  std::vector<std::uint16_t> counts(sorted.size());
  file().dataset(layout::neighbor_rows).read_selected(sorted, lists.data());
  file().dataset(layout::neighbor_counts).read_selected(sorted, counts.data());
  gather_rows_ = sorted;
  for (std::size_t i = 0; i < sorted.size(); ++i)
    for (std::size_t j = 0; j < counts[i]; ++j) gather_rows_.push_back(lists[i * kk + j]);
  std::sort(gather_rows_.begin(), gather_rows_.end());
  gather_rows_.erase(std::unique(gather_rows_.begin(), gather_rows_.end()), gather_rows_.end());
  gather_rows_.shrink_to_fit();
  auto local_of = [&](std::uint64_t row) {
    return static_cast<Index>(std::lower_bound(gather_rows_.begin(), gather_rows_.end(), row) - gather_rows_.begin());
  };
  sample_local_.resize(samples);
  sample_counts_.resize(samples);
  sample_neighbors_.assign(samples * kk, 0);
  for (std::uint64_t s = 0; s < samples; ++s) {
    const std::size_t i = static_cast<std::size_t>(std::lower_bound(sorted.begin(), sorted.end(), sample_rows_[s]) - sorted.begin());
    sample_local_[s] = local_of(sample_rows_[s]);
    sample_counts_[s] = counts[i];
    for (std::size_t j = 0; j < counts[i]; ++j) sample_neighbors_[s * kk + j] = local_of(lists[i * kk + j]);
  }
}

template <class PositionOf>
void Run::gather_sample_rows(std::uint64_t begin, std::uint64_t rows, PositionOf&& position_of) {
  auto it = std::lower_bound(gather_rows_.begin(), gather_rows_.end(), begin);
  for (; it != gather_rows_.end() && *it < begin + rows; ++it)
    gather_positions_[static_cast<std::size_t>(it - gather_rows_.begin())] = position_of(*it - begin);
}

void Run::load_sample_positions(const h5::Dataset& positions) {
  gather_positions_.resize(gather_rows_.size());
  if (!gather_rows_.empty()) positions.read_selected(gather_rows_, gather_positions_.data()->data());
}

double Run::sample_lambda() const {
  // auto_lambda (euler_step.cpp) on the gathered sample: the same points and the same
  // per-point and global medians; tests check that both agree to the bit.
  if (n_ == 0) return 1.0;
  const std::size_t samples = sample_rows_.size();
  const std::size_t kk = static_cast<std::size_t>(k());
  const std::span<const Vec3> points = gather_positions_;
  std::vector<double> medians(samples, -1.0);
  parallel_for(samples, [&](std::size_t begin, std::size_t end) {
    for (std::size_t s = begin; s < end; ++s) {
      const Index i = sample_local_[s];
      const std::span<const Index> nb(sample_neighbors_.data() + s * kk, sample_counts_[s]);
      medians[s] = median_abs_curvature(points[i], nb, points);
    }
  }, 256);
  return lambda_from_medians(std::move(medians), params_.flow.lambda_auto_factor);
}

// ---- steps ------------------------------------------------------------------------------------

TileNeighbors Run::tile_neighbors(std::size_t t) const {
  const std::uint64_t begin = tiles_.offsets[t], rows = tiles_.rows(t);
  const std::size_t kk = static_cast<std::size_t>(k());
  std::vector<std::uint32_t> global(rows * kk);
  TileNeighbors nb;
  nb.local.stride = k();
  nb.local.eps = eps_;
  nb.local.counts.resize(rows);
  file().dataset(layout::neighbor_rows).read_rows(begin, rows, global.data());
  file().dataset(layout::neighbor_counts).read_rows(begin, rows, nb.local.counts.data());
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t j = 0; j < nb.local.counts[r]; ++j) {
      const std::uint64_t g = global[r * kk + j];
      if (g < begin || g >= begin + rows) nb.halo_rows.push_back(g);
    }
  std::sort(nb.halo_rows.begin(), nb.halo_rows.end());
  nb.halo_rows.erase(std::unique(nb.halo_rows.begin(), nb.halo_rows.end()), nb.halo_rows.end());
  nb.halo_rows.shrink_to_fit();
  nb.local.indices.assign(rows * kk, 0);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t j = 0; j < nb.local.counts[r]; ++j) {
      const std::uint64_t g = global[r * kk + j];
      nb.local.indices[r * kk + j] =
          g >= begin && g < begin + rows
              ? static_cast<Index>(g - begin)
              : static_cast<Index>(rows + static_cast<std::uint64_t>(std::lower_bound(nb.halo_rows.begin(), nb.halo_rows.end(), g) -
                                                                     nb.halo_rows.begin()));
    }
  if (local_order_) {
    // While the lists are kept in memory (the steps are then fast enough for the order to
    // matter; the budget is not tight): the tile's points in the Morton order of their input
    // positions, the halo after them. The input, not the current step's positions: lists built
    // again after --resume (or on another rank count) must come out in the same order, so
    // that the run file is the same to the bit however the run was interrupted.
    std::vector<Vec3> p(rows);
    file().dataset(layout::positions).read_rows(begin, rows, p.data()->data());
    nb.order = spatial_order(p);
    const std::vector<Index> slot_of = inverse_permutation(nb.order);
    Neighborhoods permuted;
    permuted.stride = k();
    permuted.eps = eps_;
    permuted.counts.resize(rows);
    permuted.indices.assign(rows * kk, 0);
    for (std::size_t s = 0; s < rows; ++s) {
      const std::size_t r = nb.order[s];
      permuted.counts[s] = nb.local.counts[r];
      for (std::size_t j = 0; j < permuted.counts[s]; ++j) {
        const Index i = nb.local.indices[r * kk + j];
        permuted.indices[s * kk + j] = i < rows ? slot_of[i] : i;
      }
    }
    nb.local = std::move(permuted);
  }
  return nb;
}

std::shared_ptr<const TileNeighbors> Run::neighbors_of(std::size_t t, std::shared_ptr<TileNeighbors> storage) {
  if (caching_ && cache_[t]) return cache_[t];
  const std::uint64_t begin = tiles_.offsets[t], rows = tiles_.rows(t);
  // Lists read again every step: into the caller's storage, whose buffers keep their capacity
  // (a fresh one costs a zero fill of every list a step).
  auto nb = storage && local_written_[t] ? std::move(storage) : std::make_shared<TileNeighbors>();
  if (local_written_[t]) {
    // Lists in tile-local indices, written by this process's first pass: no remapping.
    nb->local.stride = k();
    nb->local.eps = eps_;
    nb->local.indices.resize(rows * static_cast<std::uint64_t>(k()));
    nb->local.counts.resize(rows);
    file().dataset(layout::neighbor_local).read_rows(begin, rows, nb->local.indices.data());
    file().dataset(layout::neighbor_counts).read_rows(begin, rows, nb->local.counts.data());
    if (local_written_[t] == 2) {
      nb->order.resize(rows);
      file().dataset(kLocalOrder).read_rows(begin, rows, nb->order.data());
      const std::vector<std::uint16_t> by_row = nb->local.counts;
      for (std::size_t s = 0; s < rows; ++s) nb->local.counts[s] = by_row[nb->order[s]];
    }
    nb->halo_rows = halo_rows_[t];
    if (local_written_[t] != 2) nb->order.clear();
    list_rows_read_ += rows;
    return nb;
  }
  *nb = tile_neighbors(t);
  list_rows_read_ += rows;
  file().dataset(layout::neighbor_local).write_rows(begin, rows, nb->local.indices.data());
  if (!nb->order.empty()) file().dataset(kLocalOrder).write_rows(begin, rows, nb->order.data());
  halo_rows_[t] = nb->halo_rows;
  halo_bytes_ += bytes(halo_rows_[t]);
  local_written_[t] = nb->order.empty() ? 1 : 2;
  if (caching_) {
    // Keep the lists while they fit next to everything else, with room for the tiles in
    // flight (twice the largest working set seen so far, at least the estimate of the slots).
    const std::uint64_t others =
        persistent_bytes() - cache_bytes_ + std::max(2 * max_working_, slots_ * slot_estimate_);
    if (others + cache_bytes_ + nb->bytes() <= options_.memory_budget) {
      cache_bytes_ += nb->bytes();
      cache_[t] = nb;
      return nb;
    }
    // Dropping the cache frees the lists no slot in flight holds (a slot keeps its own).
    caching_ = false;
    cache_.clear();
    cache_.shrink_to_fit();
    cache_bytes_ = 0;
  }
  return nb;
}

void Run::prepare_lists(OutOfCoreReport& report) {
  // The lists of every tile in tile-local indices and Morton order (kept in memory while they
  // fit, else in /run/neighbors/local), before the steps: this is part of building them, as
  // the in-core run reorders its lists before its steps. Temporal blocks and compensated
  // steps read the lists in container rows instead, unless (compensated steps) the lists and
  // the positions can be held in memory: then only while the lists still fit.
  if (temporal_blocks()) return;
  const auto t0 = Clock::now();
  bool wrote = false;
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    if (compensated() && !caching_) break;
    if (tiles_.rows(t) == 0 || local_written_[t]) continue;
    const std::shared_ptr<const TileNeighbors> nb = neighbors_of(t);
    account(caching_ && cache_[t] == nb ? 0 : nb->bytes());
    wrote = true;
  }
  // The lists just written (k + 1 values a point) reach the disk here, with the rest of
  // building them, rather than with the first step's commit. A flush is collective: every
  // rank flushes if any wrote (a rank without tiles writes none).
  if (on_any_rank(wrote)) file().flush();
  report.seconds_neighbors += seconds_since(t0);
}

void Run::read_tile_positions(std::size_t t, const TileNeighbors& nb, const h5::Dataset& source,
                              std::vector<Vec3>& local, std::vector<Vec3>& scratch, bool reorder,
                              int halo_buffer, bool listed) const {
  const std::uint64_t rows = tiles_.rows(t);
  local.resize(rows + nb.halo_rows.size());
  if (nb.order.empty() || listed) {
    source.read_rows(tiles_.offsets[t], rows, local.data()->data());
  } else {
    // The tile's rows into `scratch`, in row order; into `local` by nb.to_local (here when
    // `reorder`, else by the caller).
    scratch.resize(rows);
    source.read_rows(tiles_.offsets[t], rows, scratch.data()->data());
    if (reorder) nb.to_local(scratch, local, rows);
  }
  if (nb.halo_rows.empty()) return;
  if (halo_buffer >= 0) halo_scratch_->read(halo_buffer, t, &local[rows]);
  else source.read_selected(nb.halo_rows, local[rows].data());
}

HaloScratch* Run::streamed_halos() {
  if (halo_scratch_) return halo_scratch_.get();
  if (!options_.halo_scratch || scratch_refused_ || ranks_->size() > 1 || holding_ || blocks()) return nullptr;
  for (std::size_t t = first_tile_; t < end_tile_; ++t)
    if (tiles_.rows(t) > 0 && !local_written_[t]) return nullptr;
  scratch_refused_ = true;  // unless made below
  const fs::path directory = scratch_directory();
  // The steps give the scratch each tile's points in the order of its lists.
  const auto order_of = [this](std::size_t u) {
    std::vector<Index> order;
    if (local_written_[u] == 2) {
      order.resize(tiles_.rows(u));
      file().dataset(kLocalOrder).read_rows(tiles_.offsets[u], tiles_.rows(u), order.data());
    }
    return order;
  };
  try {
    halo_scratch_ = std::make_unique<HaloScratch>(directory, output_.string() + " (halo scratch)", halo_rows_,
                                                  tiles_.offsets, first_tile_, end_tile_, order_of);
  } catch (const io::IoError&) {
    return nullptr;  // the halos are read from the run file
  }
  // Its tables next to what the run keeps and the tiles in flight, or not at all.
  if (persistent_bytes() + slots_room() > options_.memory_budget) {
    halo_scratch_.reset();
    return nullptr;
  }
  scratch_holds_ = {};
  scratch_refused_ = false;
  return halo_scratch_.get();
}

int Run::block_length(int step) const {
  int h = std::min(std::max(1, options_.temporal_block), params_.steps - step);
  // A block never spans a rebuild: the lists are fixed inside it.
  if (params_.rebuild_interval > 0)
    h = std::min(h, params_.rebuild_interval - step % params_.rebuild_interval);
  return h;
}

void Run::build_block_lists(std::size_t t, int h, BlockSlot& s, bool morton) {
  const std::uint64_t begin = tiles_.offsets[t], rows = tiles_.rows(t);
  const std::size_t kk = static_cast<std::size_t>(k());
  const h5::Dataset list_rows = file().dataset(layout::neighbor_rows);
  const h5::Dataset list_counts = file().dataset(layout::neighbor_counts);
  s.tile = t;
  s.level_end.assign(1, rows);
  s.lists.resize(static_cast<std::size_t>(h));
  s.degenerate.assign(static_cast<std::size_t>(h), 0);
  s.rows.resize(rows);
  std::iota(s.rows.begin(), s.rows.end(), begin);
  s.ring_local.reset(0);  // grows with the rings
  // A ring row found in the current level, before the ring is numbered.
  constexpr Index kNewRow = std::numeric_limits<Index>::max();
  std::vector<std::uint64_t> level_rows, fresh;
  std::vector<std::size_t> pending;  // entries of the level's lists naming a new row
  for (std::size_t l = 0; l < static_cast<std::size_t>(h); ++l) {
    const std::size_t first = l == 0 ? 0 : s.level_end[l - 1], count = s.level_end[l] - first;
    s.global.resize(count * kk);
    s.counts.resize(count);
    if (l == 0) {
      list_rows.read_rows(begin, rows, s.global.data());
      list_counts.read_rows(begin, rows, s.counts.data());
    } else if (count > 0) {
      // The level's rows ascend (each ring is added in row order).
      level_rows.assign(s.rows.begin() + static_cast<std::ptrdiff_t>(first), s.rows.end());
      list_rows.read_selected(level_rows, s.global.data());
      list_counts.read_selected(level_rows, s.counts.data());
    }
    // The level's lists in local indices: at once where the row is the tile's or an earlier
    // ring's; an entry naming a row new in this level waits for the new ring's numbering.
    Neighborhoods& nb = s.lists[l];
    nb.stride = k();
    nb.eps = eps_;
    nb.counts.assign(s.counts.begin(), s.counts.begin() + static_cast<std::ptrdiff_t>(count));
    nb.indices.resize(count * kk);
    fresh.clear();
    pending.clear();
    for (std::size_t r = 0; r < count; ++r) {
      Index* dst = nb.indices.data() + r * kk;
      const std::uint32_t* src = s.global.data() + r * kk;
      const std::size_t listed = s.counts[r];
      for (std::size_t j = 0; j < listed; ++j) {
        const std::uint64_t g = src[j];
        if (g >= begin && g < begin + rows) {
          dst[j] = static_cast<Index>(g - begin);
          continue;
        }
        if (const Index* known = s.ring_local.find(g)) {
          if (*known != kNewRow) {
            dst[j] = *known;
            continue;
          }
        } else {
          s.ring_local.insert(g, kNewRow);
          fresh.push_back(g);
        }
        pending.push_back(r * kk + j);
      }
      std::fill(dst + listed, dst + kk, Index{0});
    }
    // The next ring: the new rows, numbered in row order after the last level.
    std::sort(fresh.begin(), fresh.end());
    for (std::size_t f = 0; f < fresh.size(); ++f)
      s.ring_local.set(fresh[f], static_cast<Index>(s.rows.size() + f));
    for (const std::size_t e : pending) nb.indices[e] = *s.ring_local.find(s.global[e]);
    s.rows.insert(s.rows.end(), fresh.begin(), fresh.end());
    s.level_end.push_back(s.rows.size());
  }
  // The rings' rows ascending, with their local indices, for one selected read.
  s.sorted_local.resize(s.rows.size() - rows);
  std::iota(s.sorted_local.begin(), s.sorted_local.end(), static_cast<Index>(rows));
  std::sort(s.sorted_local.begin(), s.sorted_local.end(), [&](Index a, Index b) { return s.rows[a] < s.rows[b]; });
  s.sorted_rows.resize(s.sorted_local.size());
  for (std::size_t i = 0; i < s.sorted_local.size(); ++i) s.sorted_rows[i] = s.rows[s.sorted_local[i]];
  list_rows_read_ += s.level_end[static_cast<std::size_t>(h) - 1];
  s.order.clear();
  s.mapped = {};
  s.all = {};
  s.views.assign(s.lists.begin(), s.lists.end());
  if (!morton || rows < 2) return;
  // The tile's points renumbered in the Morton order of their input positions (as the single
  // steps' lists, TileNeighbors): the kernel then reads its neighbours from nearby memory. The
  // lists keep their order, so no bit of a result changes.
  std::vector<Vec3> p(rows);
  file().dataset(layout::positions).read_rows(begin, rows, p.data()->data());
  s.order = spatial_order(p);
  const std::vector<Index> slot_of = inverse_permutation(s.order);
  for (Neighborhoods& nb : s.lists)
    for (Index& e : nb.indices)
      if (e < rows) e = slot_of[e];
  Neighborhoods& top = s.lists[0];
  std::vector<Index> indices(top.indices.size());
  std::vector<std::uint16_t> counts(top.counts.size());
  for (std::size_t i = 0; i < rows; ++i) {
    const std::size_t r = s.order[i];
    counts[i] = top.counts[r];
    std::copy_n(top.indices.begin() + static_cast<std::ptrdiff_t>(r * kk), kk,
                indices.begin() + static_cast<std::ptrdiff_t>(i * kk));
  }
  top.indices = std::move(indices);
  top.counts = std::move(counts);
  s.views[0] = top;
  for (std::size_t i = 0; i < rows; ++i) s.rows[i] = begin + s.order[i];
}

namespace {

// A block's lists (BlockSlot) as one record of the block-lists scratch, each array starting
// at a multiple of 8 bytes (a record's length is one): its depth and the length of its order,
// level_end, the rings' rows ascending (sorted_rows) and their local indices (sorted_local),
// the counts of every level's lists, then their entries (levels one after the other), order.
constexpr std::uint64_t padded(std::uint64_t bytes) { return (bytes + 7) / 8 * 8; }

template <class T>
void append(std::vector<unsigned char>& out, const T* data, std::size_t count) {
  const auto* p = reinterpret_cast<const unsigned char*>(data);
  out.insert(out.end(), p, p + count * sizeof(T));
}
void pad(std::vector<unsigned char>& out) { out.resize(padded(out.size()), 0); }
template <class T>
void put(std::vector<unsigned char>& out, const T* data, std::size_t count) {
  append(out, data, count);
  pad(out);
}

}  // namespace

std::uint64_t Run::store_block_lists(const BlockSlot& s, std::uint64_t offset) {
  std::vector<unsigned char>& out = block_record_;
  out.clear();
  const std::uint64_t header[2] = {s.lists.size(), s.order.size()};
  put(out, header, 2);
  put(out, s.level_end.data(), s.level_end.size());
  put(out, s.sorted_rows.data(), s.sorted_rows.size());
  put(out, s.sorted_local.data(), s.sorted_local.size());
  for (const Neighborhoods& l : s.lists) append(out, l.counts.data(), l.counts.size());
  pad(out);
  for (const Neighborhoods& l : s.lists) append(out, l.indices.data(), l.indices.size());
  pad(out);
  put(out, s.order.data(), s.order.size());
  block_lists_->write(out.data(), out.size(), offset);
  return out.size();
}

void Run::load_block_lists(std::size_t t, int h, BlockSlot& s) {
  // The record mapped (the page cache's pages, not a copy): the lists are read in place; the
  // small arrays are copied out.
  const std::uint64_t at = block_lists_at_[t - first_tile_], size = block_lists_at_[t - first_tile_ + 1] - at;
  const std::size_t d = static_cast<std::size_t>(block_lists_depth_), kk = static_cast<std::size_t>(k());
  s.mapped = block_lists_->map(at, size);
  const unsigned char* p = s.mapped.data();
  const unsigned char* const end = p + size;
  const auto next = [&](std::uint64_t bytes) {
    require(static_cast<std::uint64_t>(end - p) >= padded(bytes), "block lists: a record cut short");
    const unsigned char* const q = p;
    p += padded(bytes);
    return q;
  };
  const auto copy = [&](auto& v, std::size_t count) {
    using T = typename std::decay_t<decltype(v)>::value_type;
    v.resize(count);
    const unsigned char* const q = next(count * sizeof(T));
    if (count > 0) std::memcpy(v.data(), q, count * sizeof(T));
  };
  std::array<std::uint64_t, 2> header{};
  std::memcpy(header.data(), next(sizeof(header)), sizeof(header));
  require(header[0] == d, "block lists: a record of another depth");
  s.tile = t;
  copy(s.level_end, d + 1);
  require(header[1] == 0 || header[1] == s.level_end[0], "block lists: an order of the wrong length");
  const std::size_t rings = s.level_end[d] - s.level_end[0], listed = s.level_end[d - 1];
  copy(s.sorted_rows, rings);
  copy(s.sorted_local, rings);
  const auto* counts = reinterpret_cast<const std::uint16_t*>(next(listed * sizeof(std::uint16_t)));
  const auto* indices = reinterpret_cast<const Index*>(next(listed * kk * sizeof(Index)));
  copy(s.order, header[1]);
  require(p == end, "block lists: a record longer than its content");
  s.all = NeighborhoodsView(k(), std::span<const Index>(indices, listed * kk), std::span<const std::uint16_t>(counts, listed), eps_);
  const std::size_t levels = static_cast<std::size_t>(h);
  s.views.resize(levels);
  for (std::size_t l = 0; l < levels; ++l) {
    const std::size_t first = l == 0 ? 0 : s.level_end[l - 1];
    s.views[l] = s.all.rows(first, s.level_end[l] - first);
  }
  s.lists.clear();  // the built lists of an earlier block: not needed
  free_vector(s.rows);
  s.degenerate.assign(levels, 0);
  list_rows_read_ += listed;
}

void Run::prepare_block_lists(int d) {
  // Every tile's closure of depth d once (as a block would build it) into the block-lists
  // scratch, and its rings' rows into a halo scratch of their own: later blocks of that depth
  // read a tile's lists with one read, and its rings' positions with another.
  if (block_lists_ || blocks_refused_) return;
  blocks_refused_ = true;  // unless made below
  if (!options_.halo_scratch || ranks_->size() > 1) return;
  const fs::path directory = scratch_directory();
  std::vector<std::vector<std::uint64_t>> rings(end_tile_);
  std::uint64_t ring_bytes = 0, most_points = 0;
  BlockSlot slot;
  try {
    block_lists_ = std::make_unique<ScratchFile>(directory, output_.string() + " (block lists)");
    block_lists_depth_ = d;
    block_lists_at_.assign(end_tile_ - first_tile_ + 1, 0);
    std::uint64_t offset = 0;
    for (std::size_t t = first_tile_; t < end_tile_; ++t) {
      block_lists_at_[t - first_tile_] = offset;
      if (tiles_.rows(t) == 0) continue;
      build_block_lists(t, d, slot, true);
      offset += store_block_lists(slot, offset);
      // The order also where a resumed run finds it (to_row_order), for blocks that write
      // their tiles in it. The same as the single steps' (tile_neighbors).
      if (local_order_ && !slot.order.empty())
        file().dataset(kLocalOrder).write_rows(tiles_.offsets[t], tiles_.rows(t), slot.order.data());
      rings[t] = slot.sorted_rows;
      ring_bytes += bytes(rings[t]);
      most_points = std::max<std::uint64_t>(most_points, slot.rows.size());
      // The rings' rows kept so far and this tile's closure (no tile is in flight now): or no
      // scratch.
      const std::uint64_t working = slot.bytes() + bytes(block_record_);
      if (persistent_bytes() + ring_bytes + working > options_.memory_budget) {
        release_block_lists();
        return;
      }
      account(working + ring_bytes);
    }
    block_lists_at_[end_tile_ - first_tile_] = offset;
    // The blocks give it each tile's points in their Morton order (BlockSlot::cur).
    const auto order_of = [this](std::size_t u) { return block_order(u); };
    ring_scratch_ = std::make_unique<HaloScratch>(directory, output_.string() + " (ring scratch)", rings,
                                                  tiles_.offsets, first_tile_, end_tile_, order_of);
  } catch (const io::IoError&) {
    release_block_lists();
    return;
  }
  free_vector(block_record_);
  // Kept where the tiles in flight still fit beside it: each with the largest closure's lists
  // (`slot` holds them at their largest, with the buffers of building them, which the slots
  // reading the scratch never fill) and positions (BlockSlot::cur, next, scratch, by_row, ids,
  // and updated when compensated). Not the estimate the slots were sized with: that counts
  // the buffers of lists built from the run file, twice the lists themselves.
  const std::uint64_t per_point = (compensated() ? 5 : 4) * sizeof(Vec3) + 2 * sizeof(Index);
  const std::uint64_t per_slot = slot.bytes() + most_points * per_point;
  if (persistent_bytes() + slots_ * per_slot > options_.memory_budget) {
    release_block_lists();
    return;
  }
  // Slots sized for blocks that build their lists from the run file hold less with the
  // scratch: as many more in flight as now fit, up to the number asked for.
  const std::uint64_t fit = (options_.memory_budget - persistent_bytes()) / std::max<std::uint64_t>(per_slot, 1);
  slots_ = std::clamp<std::uint64_t>(fit, slots_, static_cast<std::uint64_t>(std::max(1, options_.tiles_in_flight)));
  ring_holds_ = {};
  blocks_refused_ = false;
}

void Run::choose_step_blocks() {
  // Only where they replace a step that would read its tile's lists from the run file: the
  // lists are not cached, nor the positions held. A block of one step reads its lists from the
  // block scratch (one mapping a tile) and its ring from the ring scratch, and keeps the tile
  // in its lists' order from step to step: the same I/O as the halo scratch's steps, with
  // the lists' conversion to local indices done once.
  step_blocks_ = false;
  if (!options_.step_blocks || !options_.halo_scratch || temporal_blocks() || compensated() || holding_ ||
      caching_ || ranks_->size() > 1)
    return;
  prepare_block_lists(1);
  step_blocks_ = block_lists_ != nullptr;
}

void Run::release_scratch() {
  halo_scratch_.reset();
  scratch_holds_ = {};
  scratch_refused_ = false;
  release_block_lists();
  blocks_refused_ = false;
}

fs::path Run::scratch_directory() const {
  const fs::path directory = output_.parent_path();
  return directory.empty() ? fs::path(".") : directory;
}

std::vector<Index> Run::block_order(std::size_t u) const {
  std::vector<Index> order;
  if (tiles_.rows(u) < 2) return order;
  if (!local_order_) {
    std::vector<Vec3> p(tiles_.rows(u));
    file().dataset(layout::positions).read_rows(tiles_.offsets[u], tiles_.rows(u), p.data()->data());
    return spatial_order(p);
  }
  order.resize(tiles_.rows(u));
  file().dataset(kLocalOrder).read_rows(tiles_.offsets[u], tiles_.rows(u), order.data());
  return order;
}

void Run::fill_ring_scratch(const h5::Dataset& source, int b) {
  // One contiguous read a tile, rather than each block reading its rings from the run file
  // (one selection of many short runs a tile).
  std::vector<Vec3> by_row, ordered;
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t rows = tiles_.rows(t);
    if (rows == 0) continue;
    by_row.resize(rows);
    source.read_rows(tiles_.offsets[t], rows, by_row.data()->data());
    const std::vector<Index> order = block_order(t);
    if (!order.empty()) {
      ordered.resize(rows);
      for (std::size_t i = 0; i < rows; ++i) ordered[i] = by_row[order[i]];
    }
    account(bytes(by_row) + bytes(ordered) + bytes(order));
    ring_scratch_->write(b, t, (order.empty() ? by_row : ordered).data());
  }
  ring_holds_[static_cast<std::size_t>(b)] = current_source();
}

int Run::buffer_holding_source(const std::array<std::string, 2>& holds) const {
  for (int b = 0; b < 2; ++b)
    if (holds[static_cast<std::size_t>(b)] == current_source()) return b;
  return -1;
}

void Run::release_block_lists() {
  block_lists_.reset();
  free_vector(block_lists_at_);
  block_lists_depth_ = 0;
  free_vector(block_record_);
  ring_scratch_.reset();
  ring_holds_ = {};
}

void Run::read_block(std::size_t t, int h, const h5::Dataset& source, BlockSlot& s, int ring_buffer, bool listed) {
  const std::uint64_t begin = tiles_.offsets[t], rows = tiles_.rows(t);
  // A shorter block than the scratch's (the last, or the last before a rebuild) takes the
  // first h levels of its closure: the closure of depth h.
  const bool cached = block_lists_ && h <= block_lists_depth_;
  require(!listed || (cached && ring_buffer >= 0), "a block in list order without its lists and rings");
  if (cached) load_block_lists(t, h, s);
  else build_block_lists(t, h, s, false);
  // Positions of step n: the tile's rows (in row order into `by_row`, moved into Morton order
  // by compute(), unless the source holds them in that order), then the rings read in
  // ascending row order.
  s.read_listed = listed && !s.order.empty();
  s.cur.resize(s.points());
  s.next.resize(s.level_end[static_cast<std::size_t>(h) - 1]);
  if (!s.order.empty() && !s.read_listed) s.by_row.resize(rows);
  source.read_rows(begin, rows, (s.order.empty() || s.read_listed ? s.cur : s.by_row).data()->data());
  if (!s.sorted_rows.empty()) {
    s.scratch.resize(s.sorted_rows.size());
    if (cached && ring_buffer >= 0) ring_scratch_->read(ring_buffer, t, s.scratch.data());
    else source.read_selected(s.sorted_rows, s.scratch.data()->data());
    for (std::size_t i = 0; i < s.sorted_rows.size(); ++i) s.cur[s.sorted_local[i]] = s.scratch[i];
  }
  if (s.ids.size() < s.next.size()) {
    s.ids.resize(s.next.size());
    std::iota(s.ids.begin(), s.ids.end(), Index{0});
  }
  rows_read_ += s.points();
}

std::size_t Run::pipeline_slots(std::uint64_t fixed) {
  // The most bytes one tile in flight holds: its positions and halo, its next positions, its
  // lists (when they are not cached) and its halo rows.
  std::vector<std::uint64_t> halo;
  if (file().exists(layout::neighbor_halo_counts))
    halo = file().dataset(layout::neighbor_halo_counts).read_all<std::uint64_t>();
  const std::uint64_t per_row =
      2 * sizeof(Vec3) + static_cast<std::uint64_t>(k() + 1) * sizeof(Index) + sizeof(std::uint16_t);
  // A block (BlockSlot) of d levels holds the tile and d rings, each taken as large as the
  // first (the halo), with lists for levels 0 .. d - 1: positions (two buffers, three when
  // compensated, and the scratch of the rings' reads), rows and sorted rows, the lists and
  // the container rows of one level's lists while it is read.
  const std::uint64_t d = blocks() ? static_cast<std::uint64_t>(block_depth(std::max(1, options_.temporal_block))) : 0;
  const std::uint64_t list_bytes = static_cast<std::uint64_t>(k()) * sizeof(Index) + sizeof(std::uint16_t);
  const std::uint64_t per_local = (compensated() ? 3 : 2) * sizeof(Vec3) + 2 * sizeof(std::uint64_t) + sizeof(Index);
  const std::uint64_t per_listed = sizeof(Vec3) + sizeof(Index) + 2 * list_bytes;
  const std::uint64_t per_ring = RowMap::kBytesPerRow;  // a ring row's entry in BlockSlot::ring_local
  slot_estimate_ = 0;
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t rows = tiles_.rows(t), h = t < halo.size() ? halo[t] : rows;
    slot_estimate_ = std::max(slot_estimate_, d > 0 ? (rows + d * h) * per_local + (rows + (d - 1) * h) * per_listed + d * h * per_ring
                                                    : rows * per_row + h * (sizeof(Vec3) + sizeof(std::uint64_t)));
  }
  // As many slots as asked for, as long as they fit next to what the run keeps (with half an
  // estimate of margin: a slot's vectors keep the capacity of the largest tile it held).
  const std::uint64_t base = persistent_bytes() + fixed;
  const std::uint64_t fit = options_.memory_budget > base
                                ? (options_.memory_budget - base) / std::max<std::uint64_t>(slot_estimate_ + slot_estimate_ / 2, 1)
                                : 1;
  slots_ = std::clamp<std::uint64_t>(fit, 1, static_cast<std::uint64_t>(std::max(1, options_.tiles_in_flight)));
  return static_cast<std::size_t>(slots_);
}

void Run::release_positions() {
  holding_ = false;
  held_cur_ = 0;
  held_ = {};
  free_vector(held_updated_);
  free_vector(held_base_);
  free_vector(held_halo_);
  free_vector(held_slot_);
  free_vector(held_sample_);
  held_list_order_ = false;
  held_bytes_ = 0;
}

void Run::hold_positions() {
  release_positions();
  // Every tile's lists in memory, every halo row in this rank's tiles, and room for two
  // copies of every tile with its halo (three when compensated) next to what the run keeps
  // and the tiles in flight.
  bool able = !temporal_blocks() && caching_;
  std::vector<std::uint64_t> base(tiles_.size() + 1, 0);
  std::uint64_t total = 0, halo_total = 0;
  for (std::size_t t = first_tile_; t < end_tile_ && able; ++t) {
    base[t] = total;
    if (tiles_.rows(t) == 0) continue;
    const TileNeighbors* nb = cache_[t].get();
    able = nb != nullptr;
    for (std::size_t j = 0; able && j < nb->halo_rows.size(); ++j)
      able = nb->halo_rows[j] >= my_first_row() && nb->halo_rows[j] < my_end_row();
    if (!able) break;
    total += tiles_.rows(t) + nb->halo_rows.size();
    halo_total += nb->halo_rows.size();
  }
  const std::uint64_t copies = compensated() ? 3 : 2;
  const bool index_sample = ranks_->size() == 1 && auto_lambda_on() && params_.lambda_every_step;
  const std::uint64_t need = copies * total * sizeof(Vec3) + halo_total * sizeof(std::uint64_t) + bytes(base) +
                             (my_end_row() - my_first_row()) * sizeof(Index) +  // the inverse orders below
                             (index_sample ? gather_rows_.size() * sizeof(std::uint64_t) : 0);
  able = able && persistent_bytes() + need + slots_room() <= options_.memory_budget;
  // Every rank holds, or none: the steps' commit records (list order or not) and the
  // collective writes of to_row_order are shared.
  if (!on_every_rank(able)) return;
  // Tile u's point at row offset r sits at slot inverse[offsets[u] - first + r] of its lists.
  std::vector<Index> inverse(my_end_row() - my_first_row());
  bool list_order = local_order_;
  for (std::size_t u = first_tile_; u < end_tile_; ++u) {
    const std::uint64_t rows = tiles_.rows(u), at = tiles_.offsets[u] - my_first_row();
    if (rows == 0) continue;
    const std::vector<Index>& order = cache_[u]->order;
    if (order.empty()) list_order = false;
    for (std::uint64_t r = 0; r < rows; ++r)
      inverse[at + (order.empty() ? r : order[r])] = static_cast<Index>(r);
  }
  list_order = on_every_rank(list_order);
  held_halo_.assign(tiles_.size(), {});
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    if (tiles_.rows(t) == 0) continue;
    const std::vector<std::uint64_t>& halo = cache_[t]->halo_rows;
    std::vector<std::uint64_t>& from = held_halo_[t];
    from.resize(halo.size());
    for (std::size_t j = 0; j < halo.size(); ++j) {
      const std::size_t u = static_cast<std::size_t>(
          std::upper_bound(tiles_.offsets.begin(), tiles_.offsets.end(), halo[j]) - tiles_.offsets.begin() - 1);
      from[j] = base[u] + inverse[halo[j] - my_first_row()];
    }
  }
  account(need);
  held_base_ = std::move(base);
  for (auto& h : held_) h.resize(total);
  if (compensated()) held_updated_.resize(total);
  held_slot_ = std::move(inverse);
  if (index_sample) {
    held_sample_.resize(gather_rows_.size());
    for (std::size_t i = 0; i < gather_rows_.size(); ++i) {
      const std::uint64_t g = gather_rows_[i];
      const std::size_t u = static_cast<std::size_t>(
          std::upper_bound(tiles_.offsets.begin(), tiles_.offsets.end(), g) - tiles_.offsets.begin() - 1);
      held_sample_[i] = held_base_[u] + held_slot_[g - my_first_row()];
    }
  }
  held_list_order_ = list_order;
  held_bytes_ = need;
  holding_ = true;
  // Like the in-core run's move of its cloud into Morton order, part of the setup.
  load_held(file().dataset(current_source()));
}

void Run::to_row_order() {
  // The positions of the current buffer, written in list order, into the other buffer in row
  // order, tile by tile, and committed: then the state names that buffer (the same positions;
  // killed before the commit, the run resumes from the one in list order and does this again).
  // From the positions held in memory while they are there (the run's last step wrote them),
  // else from the file (a resumed run).
  if (!source_in_list_order()) return;
  const bool held = holding_ && held_list_order_;
  const h5::Dataset source = file().dataset(current_source());
  h5::Dataset target = file().dataset(positions_buffer(target_buffer()));
  const h5::Dataset order_rows = file().dataset(kLocalOrder);
  std::vector<Vec3> in_list_order, in_row_order;
  std::vector<Index> order_read;
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t begin = tiles_.offsets[t], rows = tiles_.rows(t);
    if (rows == 0) continue;
    in_row_order.resize(rows);
    const Vec3* listed = nullptr;
    const Index* order = nullptr;
    if (held) {
      listed = held_[static_cast<std::size_t>(held_cur_)].data() + held_base_[t];
      order = cache_[t]->order.data();
      account(bytes(in_row_order));
    } else {
      in_list_order.resize(rows);
      order_read.resize(rows);
      account(bytes(in_list_order) + bytes(in_row_order) + bytes(order_read) + rows);  // and `seen`
      source.read_rows(begin, rows, in_list_order.data()->data());
      order_rows.read_rows(begin, rows, order_read.data());
      std::vector<char> seen(rows, 0);
      for (const Index r : order_read) {
        if (r >= rows || seen[r]) file().fail(kLocalOrder, "not a permutation of the tile's rows");
        seen[r] = 1;
      }
      listed = in_list_order.data();
      order = order_read.data();
    }
    parallel_for(rows, [&](std::size_t b, std::size_t e) {
      for (std::size_t r = b; r < e; ++r) in_row_order[order[r]] = listed[r];
    }, 8192);
    target.write_rows(begin, rows, in_row_order.data()->data(), h5::Transfer::Collective);
  }
  // Collective writes: as many per rank as the rank with the most tiles.
  for (std::uint64_t w = my_tiles(), writes = tiles_to_write(); w < writes; ++w)
    target.write_rows<double>(0, 0, nullptr, h5::Transfer::Collective);
  state_[kStepBuffer] = target_code(false);
  commit_state();
}

void Run::copy_halo(std::vector<Vec3>& buffer, std::size_t t) const {
  const std::vector<std::uint64_t>& from = held_halo_[t];
  Vec3* const halo = buffer.data() + held_base_[t] + tiles_.rows(t);
  parallel_for(from.size(), [&](std::size_t b, std::size_t e) {
    for (std::size_t j = b; j < e; ++j) halo[j] = buffer[from[j]];
  }, 8192);
}

void Run::load_held(const h5::Dataset& source) {
  // Each tile's rows, read whole and put in the order of its lists; the halos are copied in
  // by the steps.
  std::vector<Vec3> by_row;
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t rows = tiles_.rows(t);
    if (rows == 0) continue;
    Vec3* const local = held_[static_cast<std::size_t>(held_cur_)].data() + held_base_[t];
    const std::vector<Index>& order = cache_[t]->order;
    if (order.empty()) {
      source.read_rows(tiles_.offsets[t], rows, local->data());
    } else {
      by_row.resize(rows);
      account(bytes(by_row));
      source.read_rows(tiles_.offsets[t], rows, by_row.data()->data());
      parallel_for(rows, [&](std::size_t b, std::size_t e) {
        for (std::size_t r = b; r < e; ++r) local[r] = by_row[order[r]];
      }, 8192);
    }
    rows_read_ += rows;
  }
}

bool Run::run_steps(OutOfCoreReport& report) {
  // A run stopped or killed while its positions were held leaves them in list order: all
  // that follows reads them in row order.
  to_row_order();
  const int start = static_cast<int>(state_[kCompletedSteps]);
  report.resumed_from = start;
  cache_.assign(tiles_.size(), {});
  local_written_.assign(tiles_.size(), 0);
  halo_rows_.assign(tiles_.size(), {});
  local_order_ = file().exists(kLocalOrder);
  if (state_[kFinishPasses] > 0) {
    // The finish has begun: the steps ended at `start` (stopped early, or all done), on
    // positions a pass may have overwritten since; the stop's lambda was kept with the first.
    final_steps_ = start;
    if (start < params_.steps) file().dataset(kStopLambda).read_rows(0, 1, &stop_lambda_);
    return true;
  }
  const bool every_step = auto_lambda_on() && params_.lambda_every_step;
  double lambda = params_.flow.lambda;
  // The step whose positions the lists in force were built from (a rebuild at `start` itself
  // may not have happened yet: then the loop does it).
  const int built_at = static_cast<int>(state_[kNeighborsStep]);
  if (auto_lambda_on() && !every_step) {
    if (built_at > 0 && built_at < start) {
      // Measured once after the last rebuild, on positions that are gone: the step log has it.
      double entry[2];
      file().dataset(layout::run_step_log).read_rows(static_cast<std::uint64_t>(start - 1), 1, entry);
      lambda = entry[0];
    } else {
      load_sample_positions(file().dataset(built_at == 0 ? std::string(layout::positions) : current_source()));
      lambda = sample_lambda();
      free_vector(gather_positions_);
    }
  }
  if (every_step) load_sample_positions(file().dataset(current_source()));
  std::vector<Index> identity(max_tile_rows_);
  std::iota(identity.begin(), identity.end(), Index{0});
  h5::Dataset log = file().dataset(layout::run_step_log);
  const std::uint64_t writes = tiles_to_write();
  int committed_here = 0;
  // The automatic stop looks at the lambdas of every step so far (should_stop): those of the
  // steps before `start` from the step log, so that a resumed run stops where an
  // uninterrupted one does.
  std::vector<double> lambdas;
  if (stops_automatically() && start > 0) {
    std::vector<double> entries(2 * static_cast<std::size_t>(start));
    log.read_rows(0, static_cast<std::uint64_t>(start), entries.data());
    for (int s = 0; s < start; ++s) lambdas.push_back(entries[2 * static_cast<std::size_t>(s)]);
  }
  // The tiles of a step go through a bounded pipeline (pipeline.hpp): tile i+1 and its halo
  // are read while tile i is computed and tile i-1 written, all HDF5 calls on this thread.
  // Each slot holds one tile in flight; every slot's buffers count in the budget.
  struct Slot {
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
    StepStats stats;
    const std::vector<Vec3>& result() const { return nb->order.empty() ? next : local; }
  };
  std::vector<std::size_t> work;
  for (std::size_t t = first_tile_; t < end_tile_; ++t)
    if (tiles_.rows(t) > 0) work.push_back(t);
  std::size_t slot_count = pipeline_slots(bytes(identity));
  // After the slots are sized: the lists are cached only next to room for the tiles in flight.
  prepare_lists(report);
  {
    const auto th = Clock::now();
    hold_positions();
    choose_step_blocks();
    report.seconds_neighbors += seconds_since(th);
  }
  // Positions held in list order, a slot holds no positions: then every tile of a step is in
  // flight at once, so that the worker never waits for this thread (the commit of the last
  // step, before the first write, mostly waits for the disk).
  std::vector<Slot> slots(std::max(slot_count, work.size()));
  const auto slots_bytes = [&] {
    std::uint64_t total = bytes(identity);
    for (const Slot& s : slots) {
      total += bytes(s.local) + bytes(s.next) + bytes(s.slot_of) + (s.own ? s.own->bytes() : 0);
      if (s.nb && s.nb != s.own && !(caching_ && cache_[s.tile] == s.nb)) total += s.nb->bytes();
    }
    return total;
  };
  // Temporal blocks (OutOfCoreOptions::temporal_block) and compensated steps: h steps per load
  // of a tile and its h-ring (2 h-ring) closure, in a pipeline of their own.
  std::vector<BlockSlot> block_slots(blocks() ? slot_count : 0);
  const auto block_bytes = [&] {
    std::uint64_t total = 0;
    for (const BlockSlot& b : block_slots) total += b.accounted;
    return total;
  };
  // The commit of a step (commit_state) mostly waits for the disk. In a single process it is
  // left pending and finished by this thread while the worker computes the next step's first
  // tile: before the next step writes anything (it overwrites the buffer the commit leaves
  // behind), before anything else touches the file, and before this function returns. The
  // step's progress is reported once it is committed, as before.
  bool commit_pending = false;
  // A held step in list order in a single process goes further: it leaves its writes to the
  // next step, whose pipeline reads nothing from the file, so this thread writes the tiles
  // (from the held buffer: the next step only reads it) and commits them while the worker
  // computes. The step's computes then follow the last one's without waiting for its last
  // tile to be written. `lagged.record` is the state to commit once its tiles are written.
  struct Lagged {
    bool pending = false;
    int buffer = 0;
    std::string target;
    std::vector<std::int64_t> record;
    std::size_t written = 0;  // items of `work` written
  } lagged;
  // Writes the lagged step's items below `end` and, once they are all written, commits it.
  const auto write_lagged = [&](std::size_t end) {
    if (!lagged.pending) return;
    const std::vector<Vec3>& from = held_[static_cast<std::size_t>(lagged.buffer)];
    h5::Dataset target = file().dataset(lagged.target);
    for (; lagged.written < std::min(end, work.size()); ++lagged.written) {
      const std::size_t t = work[lagged.written];
      target.write_rows(tiles_.offsets[t], tiles_.rows(t), from[held_base_[t]].data());
      file().start_writeback();
    }
    if (lagged.written < work.size()) return;
    commit_state(lagged.record);
    lagged.pending = false;
    progress("step", static_cast<std::uint64_t>(lagged.record[kCompletedSteps]),
             static_cast<std::uint64_t>(params_.steps));
  };
  const auto finish_commit = [&] {
    write_lagged(work.size());
    if (!commit_pending) return;
    commit_state();
    commit_pending = false;
    progress("step", static_cast<std::uint64_t>(state_[kCompletedSteps]), static_cast<std::uint64_t>(params_.steps));
  };
  // Before anything but the next step reads the positions: the commit finished, and the
  // positions in row order.
  const auto finish_commit_timed = [&] {
    const auto tc = Clock::now();
    finish_commit();
    to_row_order();
    report.seconds_steps += seconds_since(tc);
  };
  for (int step = start; step < params_.steps;) {
    if (rebuild_due(step) && state_[kNeighborsStep] != step) finish_commit_timed();
    auto t0 = Clock::now();
    if (rebuild_due(step) && state_[kNeighborsStep] != step) {
      rebuild_neighbors(step);
      prepare_lists(report);
      hold_positions();
      choose_step_blocks();
      if (blocks() && block_slots.empty()) {
        // Compensated steps whose positions no longer fit once the lists are rebuilt, or plain
        // steps as blocks: blocks from here, with slots sized for them.
        slot_count = pipeline_slots(bytes(identity));
        block_slots.resize(slot_count);
      }
      ++report.rebuilds;
      if (auto_lambda_on() && !every_step) {
        lambda = sample_lambda();
        free_vector(gather_positions_);
      }
      report.seconds_neighbors += seconds_since(t0);
      t0 = Clock::now();
    }
    // smooth()'s rule, and the first step of this call (the step log keeps the lambda last
    // measured for the steps that measure none).
    if (every_step && (step == start || measures_lambda_before(params_, step))) {
      lambda = sample_lambda();
      // As in smooth(), the lambda of the first step (of this call) is part of the setup.
      if (step == start) {
        report.seconds_neighbors += seconds_since(t0);
        t0 = Clock::now();
      }
    }
    if (stops_automatically()) {
      lambdas.push_back(lambda);
      if (should_stop(params_, lambdas)) {
        report.seconds_steps += seconds_since(t0);
        finish_commit_timed();
        final_steps_ = step;
        stop_lambda_ = lambda;
        return true;
      }
    }
    const h5::Dataset source = file().dataset(current_source());
    const std::string target_name = positions_buffer(target_buffer());
    h5::Dataset target = file().dataset(target_name);
    const int h = block_length(step);
    // The lambda sample's positions after this step (or block), gathered as its tiles are
    // written: only where the next step measures the lambda (smooth()'s rule: every step of
    // the anisotropic flow, the last of the isotropic one). A resumed run reads them anew.
    const bool gather_sample = every_step && step + h < params_.steps && measures_lambda_before(params_, step + h);
    // Whether this step writes its positions in list order (held_list_order_): not the last
    // step, nor one before a rebuild, which write row order as they go instead of after.
    const bool list_order_step = !blocks() && holding_ && held_list_order_ && step + 1 < params_.steps &&
                                 !rebuild_due(step + 1);
    // Whether its writes go to the next step (Lagged): not where the run stops after it.
    const bool lag_writes = list_order_step && ranks_->size() == 1 && !compensated() &&
                            !(options_.stop_after_steps >= 0 && committed_here + h >= options_.stop_after_steps);
    // Streamed steps write list order too, on the same terms, while the halo scratch carries
    // the halos (the run file's rows of a halo are then not in row order) and every tile's
    // lists have an order; the slots then hold no copy of a tile in row order.
    HaloScratch* const halos = !blocks() && !holding_ ? streamed_halos() : nullptr;
    const bool streamed_list_order = halos != nullptr && streamed_lists_ordered() && step + 1 < params_.steps &&
                                     !rebuild_due(step + 1);
    std::vector<std::size_t> block_degenerate(static_cast<std::size_t>(h), 0);
    std::size_t degenerate = 0;
    PipelineStages stages;
    // A compensated step with its positions held (shrink_compensation.hpp), in two passes: the
    // plain step of every tile into held_updated_ (with the first tile's compute), then their
    // halos copied in; each tile's compute then compensates from both.
    std::vector<StepStats> plain_stats(compensated() ? tiles_.size() : 0);
    bool updated_ready = false;
    // Streamed steps: the buffer of the halo scratch this step writes.
    const int written_halos = target_buffer();
    // Blocks with their lists and rings from the scratch; those of them that write list order.
    bool scratch_block = false, block_list_order = false;
    if (blocks()) {
      // The block lists of this depth, made once (the first block at most reads them back;
      // the blocks after it are no deeper until the next rebuild); the rings from the ring
      // scratch where it holds the source's.
      {  // part of building the lists, as prepare_lists
        const auto tp = Clock::now();
        prepare_block_lists(block_depth(h));
        if (block_slots.size() < slots_) {
          slot_count = static_cast<std::size_t>(slots_);
          block_slots.resize(slot_count);
        }
        report.seconds_neighbors += seconds_since(tp);
        t0 += Clock::now() - tp;
      }
      scratch_block = ring_scratch_ && block_depth(h) <= block_lists_depth_;
      ran_blocks_ = true;
      if (step_blocks_) report.step_blocks = true;
      int ring_from = ring_scratch_ ? buffer_holding_source(ring_holds_) : -1;
      if (scratch_block && ring_from < 0) {
        // The first block of a call or after a rebuild: the rings' positions into the buffer
        // this block does not write.
        ring_from = 1 - written_halos;
        fill_ring_scratch(source, ring_from);
      }
      if (ring_scratch_) ring_holds_[static_cast<std::size_t>(written_halos)].clear();
      // Blocks whose lists and rings come from the scratch write their tiles in Morton order
      // (BlockSlot::order) where the next block reads them so too (its lists come from the
      // scratch: not the last block, nor one before a rebuild); nothing is moved into row
      // order and back.
      const bool listed_in = source_in_list_order();
      block_list_order = scratch_block && local_order_ && !gather_sample && step + h < params_.steps &&
                         !rebuild_due(step + h) && block_depth(block_length(step + h)) <= block_lists_depth_;
      stages.read = [&, ring_from, listed_in](std::size_t item, std::size_t slot) {
        read_block(work[item], block_depth(h), source, block_slots[slot], ring_from, listed_in);
        block_slots[slot].write_listed = block_list_order;
        // The plain updates of a compensated step, counted with the rest of the block.
        if (compensated()) block_slots[slot].updated.resize(block_slots[slot].cur.size());
        largest_local_ = std::max<std::uint64_t>(largest_local_, block_slots[slot].cur.size());
        block_slots[slot].accounted = block_slots[slot].bytes();
        account(block_bytes() + bytes(identity));
      };
      stages.compute = [&](std::size_t slot) {
        block_slots[slot].compute(params_.flow, lambda, params_.shrink_compensation);
      };
      stages.write = [&](std::size_t, std::size_t slot) {
        BlockSlot& b = block_slots[slot];
        const std::uint64_t begin = tiles_.offsets[b.tile], rows = tiles_.rows(b.tile);
        const Vec3* const result = b.tile_rows();
        target.write_rows(begin, rows, result->data(), h5::Transfer::Collective);
        file().start_writeback();
        if (scratch_block) ring_scratch_->write(written_halos, b.tile, b.cur.data());
        b.mapped = {};  // the tile's lists, mapped: unmapped as soon as it is done
        b.accounted = b.bytes();
        for (int j = 0; j < h; ++j) block_degenerate[static_cast<std::size_t>(j)] += b.degenerate[static_cast<std::size_t>(j)];
        // One step a block (with a lambda of every step, a block is one step).
        if (gather_sample) gather_sample_rows(begin, rows, [&](std::uint64_t r) { return result[r]; });
      };
    } else {
    if (holding_) {
      // Positions held in memory: the source is held_[held_cur_] (read from the file before
      // the first step, load_held), each tile's step goes into held_[1 - held_cur_] in the
      // lists' order, and from there into the file: as it is on a list_order_step, else
      // through the slot's `next` in row order.
      stages.read = [&](std::size_t item, std::size_t slot) {
        Slot& s = slots[slot];
        s.tile = work[item];
        s.nb = neighbors_of(s.tile);
        const std::uint64_t rows = tiles_.rows(s.tile);
        const std::vector<std::uint64_t>& from = held_halo_[s.tile];
        if (list_order_step) free_vector(s.next);  // the step is written from the held buffer
        else s.next.resize(rows);
        largest_local_ = std::max<std::uint64_t>(largest_local_, rows + from.size());
        account(slots_bytes());
      };
      // The step's rows of a tile in file order (`next`), from the held buffer (Morton order
      // within the tile when the lists are). A scattered copy: with one compute thread the
      // writing thread, otherwise idle, does it; with more the compute threads share it, since
      // on the writing thread it cost about as much as half the isotropic step (1M points,
      // 2 threads: 16.3M point-steps/s out of core with it there, 19.1M without).
      const bool scatter_on_compute = thread_count() > 1;
      const auto plain_updates = [&] {
        std::vector<Vec3>& cur = held_[static_cast<std::size_t>(held_cur_)];
        for (const std::size_t t : work) {
          const std::uint64_t rows = tiles_.rows(t), base = held_base_[t];
          copy_halo(cur, t);
          const std::span<const Vec3> local(cur.data() + base, rows + held_halo_[t].size());
          plain_stats[t] = euler_step(local, cache_[t]->local, std::span<const Index>(identity.data(), rows),
                                      params_.flow, lambda, std::span<Vec3>(held_updated_.data() + base, rows));
        }
        for (const std::size_t t : work) copy_halo(held_updated_, t);
      };
      const auto to_file_order = [this](Slot& s) {
        const std::uint64_t rows = tiles_.rows(s.tile);
        const Vec3* const out = held_[static_cast<std::size_t>(1 - held_cur_)].data() + held_base_[s.tile];
        const std::vector<Index>& order = s.nb->order;
        parallel_for(rows, [&](std::size_t b, std::size_t e) {
          if (order.empty()) std::copy(out + b, out + e, s.next.begin() + static_cast<std::ptrdiff_t>(b));
          else
            for (std::size_t r = b; r < e; ++r) s.next[order[r]] = out[r];
        }, 8192);
      };
      stages.compute = [&, to_file_order, scatter_on_compute, plain_updates](std::size_t slot) {
        Slot& s = slots[slot];
        const std::uint64_t rows = tiles_.rows(s.tile), base = held_base_[s.tile];
        std::vector<Vec3>& cur = held_[static_cast<std::size_t>(held_cur_)];
        const std::vector<std::uint64_t>& from = held_halo_[s.tile];
        const std::span<const Vec3> local(cur.data() + base, rows + from.size());
        const std::span<Vec3> out(held_[static_cast<std::size_t>(1 - held_cur_)].data() + base, rows);
        if (compensated()) {
          if (!updated_ready) plain_updates();
          updated_ready = true;
          s.stats = plain_stats[s.tile];
          compensate_shrinkage(local, std::span<const Vec3>(held_updated_.data() + base, rows + from.size()),
                               s.nb->local, std::span<const Index>(identity.data(), rows),
                               params_.shrink_compensation, out);
        } else {
          // The halo from the tiles holding it, here on the compute threads (step-n positions:
          // nothing writes them now; each tile's halo has its own place in the held buffer).
          copy_halo(cur, s.tile);
          s.stats = euler_step(local, s.nb->local, std::span<const Index>(identity.data(), rows), params_.flow,
                               lambda, out);
        }
        if (scatter_on_compute && !list_order_step) to_file_order(s);
      };
      stages.write = [&, to_file_order, scatter_on_compute](std::size_t, std::size_t slot) {
        Slot& s = slots[slot];
        const std::uint64_t begin = tiles_.offsets[s.tile], rows = tiles_.rows(s.tile);
        degenerate += s.stats.degenerate;
        const Vec3* const out = held_[static_cast<std::size_t>(1 - held_cur_)].data() + held_base_[s.tile];
        if (lag_writes) {
          // written by the next step (Lagged)
        } else if (list_order_step) {
          target.write_rows(begin, rows, out->data(), h5::Transfer::Collective);
        } else {
          if (!scatter_on_compute) to_file_order(s);
          target.write_rows(begin, rows, s.next.data()->data(), h5::Transfer::Collective);
        }
        if (!lag_writes) file().start_writeback();
        if (gather_sample && held_sample_.empty())
          gather_sample_rows(begin, rows, [&](std::uint64_t r) {
            return list_order_step ? out[held_slot_[begin + r - my_first_row()]] : s.next[r];
          });
        s.nb.reset();
      };
    } else {
    // Streamed: each tile's halo from the halo scratch where it holds the source's (the
    // previous step wrote it), else from the run file; the step writes the target's.
    const int halos_from = halos != nullptr ? buffer_holding_source(scratch_holds_) : -1;
    if (halos != nullptr) scratch_holds_[static_cast<std::size_t>(written_halos)].clear();
    // A source in list order was written by the previous step of this call, with the halos.
    const bool source_listed = source_in_list_order();
    require(!source_listed || halos_from >= 0, "a streamed step in list order without its halos");
    stages.read = [&, halos_from, source_listed](std::size_t item, std::size_t slot) {
      Slot& s = slots[slot];
      s.tile = work[item];
      // The slot's lists are reused from tile to tile unless they are the cache's.
      if (!s.own) s.own = std::make_shared<TileNeighbors>();
      s.nb = neighbors_of(s.tile, s.own);
      s.read_in_list_order = source_listed && !s.nb->order.empty();
      read_tile_positions(s.tile, *s.nb, source, s.local, s.next, false, halos_from, s.read_in_list_order);
      rows_read_ += s.local.size();
      s.next.resize(tiles_.rows(s.tile));
      // Sized here, not by the compute: this thread reads every slot's vectors (slots_bytes).
      if (streamed_list_order && gather_sample && !s.nb->order.empty()) s.slot_of.resize(tiles_.rows(s.tile));
      largest_local_ = std::max<std::uint64_t>(largest_local_, s.local.size());
      account(slots_bytes());
    };
    stages.compute = [&](std::size_t slot) {
      Slot& s = slots[slot];
      const std::size_t rows = s.next.size();
      const std::vector<Index>& order = s.nb->order;
      if (!order.empty() && !s.read_in_list_order) s.nb->to_local(s.next, s.local, rows);
      s.stats = euler_step(s.local, s.nb->local, std::span<const Index>(identity.data(), rows), params_.flow,
                           lambda, s.next);
      if (order.empty()) return;
      if (!streamed_list_order) {
        s.nb->to_rows(s.next, s.local, rows);
      } else if (gather_sample) {
        parallel_for(rows, [&](std::size_t b, std::size_t e) {
          for (std::size_t i = b; i < e; ++i) s.slot_of[order[i]] = static_cast<Index>(i);
        }, 8192);
      }
    };
    stages.write = [&](std::size_t, std::size_t slot) {
      Slot& s = slots[slot];
      const std::uint64_t begin = tiles_.offsets[s.tile], rows = tiles_.rows(s.tile);
      degenerate += s.stats.degenerate;
      // `next`: the step in the lists' order (row order for a tile without one).
      const bool listed = streamed_list_order && !s.nb->order.empty();
      const std::vector<Vec3>& result = listed ? s.next : s.result();
      target.write_rows(begin, rows, result.data()->data(), h5::Transfer::Collective);
      file().start_writeback();
      if (halos != nullptr) halos->write(written_halos, s.tile, s.next.data());
      if (gather_sample)
        gather_sample_rows(begin, rows, [&](std::uint64_t r) { return result[listed ? s.slot_of[r] : r]; });
      s.nb.reset();  // lists that are not cached are freed with their tile
    };
    }
    }
    if (lagged.pending) {
      // The previous step's tiles, one as each of this step's after the first is read
      // (nothing is read from the file: the positions are held), so that they overlap the
      // computes from the first on; the last before this step's first write.
      stages.read = [&, read = stages.read](std::size_t item, std::size_t slot) {
        write_lagged(item);
        read(item, slot);
      };
    }
    if (commit_pending || lagged.pending) {
      // The pending commit: before the first write (the worker computes the tiles read
      // meanwhile).
      stages.write = [&, write = stages.write](std::size_t item, std::size_t slot) {
        finish_commit();
        write(item, slot);
      };
    }
    std::size_t in_flight = list_order_step ? slots.size() : slot_count;
    if (holding_ && !blocks() && !list_order_step) {
      // A held step in row order (the last, or one before a rebuild): a slot holds only its
      // tile's rows in file order (`next`), so as many as fit in the room kept for the slots
      // are in flight, and the computes need not wait for the previous step's commit.
      const std::uint64_t room = slots_room();
      const std::uint64_t per_slot = std::max<std::uint64_t>(1, max_tile_rows_ * sizeof(Vec3));
      in_flight = static_cast<std::size_t>(std::clamp<std::uint64_t>(room / per_slot, slot_count, slots.size()));
    }
    most_in_flight_ = std::max<std::uint64_t>(most_in_flight_, std::min(in_flight, work.size()));
    run_pipeline(work.size(), in_flight, stages);
    if (holding_) held_cur_ = 1 - held_cur_;
    if (holding_ && gather_sample && !held_sample_.empty()) {
      const std::vector<Vec3>& now = held_[static_cast<std::size_t>(held_cur_)];
      parallel_for(held_sample_.size(), [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) gather_positions_[i] = now[held_sample_[i]];
      }, 4096);
    }
    if (halos != nullptr) {
      scratch_holds_[static_cast<std::size_t>(written_halos)] = positions_buffer(written_halos);
      report.halo_scratch = true;
    }
    if (scratch_block) {
      ring_holds_[static_cast<std::size_t>(written_halos)] = positions_buffer(written_halos);
      report.halo_scratch = true;
    }
    // Collective writes: as many per rank as the rank with the most tiles.
    for (std::uint64_t w = my_tiles(); w < writes; ++w) target.write_rows<double>(0, 0, nullptr, h5::Transfer::Collective);
    if (!blocks()) block_degenerate[0] = degenerate;
    if (gather_sample && ranks_->size() > 1) {
      // Each rank updated the sample's positions in its own tiles: exchange them.
      const auto first = std::lower_bound(gather_rows_.begin(), gather_rows_.end(), my_first_row()) - gather_rows_.begin();
      const auto end = std::lower_bound(gather_rows_.begin(), gather_rows_.end(), my_end_row()) - gather_rows_.begin();
      std::fill(gather_positions_.begin(), gather_positions_.begin() + first, Vec3::Zero());
      std::fill(gather_positions_.begin() + end, gather_positions_.end(), Vec3::Zero());
      ranks_->merge(std::span<double>(gather_positions_.data()->data(), 3 * gather_positions_.size()));
    }
    for (int j = 0; j < h; ++j) {
      degenerate = static_cast<std::size_t>(ranks_->sum(block_degenerate[static_cast<std::size_t>(j)]));
      const double entry[2] = {lambda, static_cast<double>(degenerate)};
      if (ranks_->rank() == 0) log.write_rows(static_cast<std::uint64_t>(step + j), 1, entry);
    }
    step += h;
    state_[kCompletedSteps] = step;
    state_[kStepBuffer] = target_code(list_order_step || streamed_list_order || block_list_order);
    committed_here += h;
    const bool stopping = options_.stop_after_steps >= 0 && committed_here >= options_.stop_after_steps;
    if (lag_writes) {
      write_lagged(work.size());  // done by this step's reads already
      lagged = {true, held_cur_, target_name, state_, 0};
    } else if (ranks_->size() == 1 && step < params_.steps && !stopping) {
      commit_pending = true;
    } else {
      commit_state();
      progress("step", static_cast<std::uint64_t>(step), static_cast<std::uint64_t>(params_.steps));
    }
    report.steps = step;
    report.position_rows_read = rows_read_;
    report.list_rows_read = list_rows_read_;
    report.lambda = lambda;
    report.eps = eps_;
    report.degenerate = degenerate;
    report.seconds_steps += seconds_since(t0);
    if (stopping && step < params_.steps) return false;
  }
  finish_commit_timed();
  final_steps_ = params_.steps;
  return true;
}

// ---- the quadric finish -------------------------------------------------------------------------

std::optional<FinishLists> Run::finish_lists(std::size_t t, double halo, const LocalSet& local,
                                             const QuadricProjectionParams& q) const {
  // finish_with_quadrics's lists on the tile's gathered points (sorted by original index: the
  // canonical tie rule). Empty (the halo must grow) unless every row is certain to be the
  // in-core one: its farthest entry lies inside what was gathered.
  constexpr double inf = std::numeric_limits<double>::infinity();
  const std::size_t n = local.positions.size(), kk = static_cast<std::size_t>(q.k);
  const bool all = covers_all(t, halo);
  FinishLists lists;
  lists.fits = build_neighborhoods(local.positions, local.queries, q.k, inf);
  std::vector<char> in_tile(n, 0), named(n, 0);
  for (const Index i : local.queries) in_tile[i] = 1;
  for (std::size_t r = 0; r < lists.fits.size(); ++r) {
    const std::span<const Index> row = lists.fits.of(r);
    if (!all && (row.size() < kk || !((local.positions[row.back()] - local.positions[local.queries[r]]).norm() <
                                       halo * (1.0 - kHaloMargin))))
      return std::nullopt;
    for (const Index j : row) named[j] = !in_tile[j];
  }
  std::vector<Index> halo_queries;
  for (std::size_t i = 0; i < n; ++i)
    if (named[i]) halo_queries.push_back(static_cast<Index>(i));
  // A normal reads the first normal_neighbors of the point's row; a prefix of the canonical
  // order is the canonical order of fewer neighbours.
  const int m = std::min(q.k, q.normal_neighbors);
  const Neighborhoods near = build_neighborhoods(local.positions, halo_queries, m, inf);
  if (!all) {
    // A halo point's ball lies inside the box around the tile that was gathered.
    const Box& b = tiles_.bounds[t];
    for (std::size_t r = 0; r < near.size(); ++r) {
      const std::span<const Index> row = near.of(r);
      if (row.size() < static_cast<std::size_t>(m)) return std::nullopt;
      const Vec3& p = local.positions[halo_queries[r]];
      const double reach = (local.positions[row.back()] - p).norm() + halo * kHaloMargin;
      for (Eigen::Index c = 0; c < 3; ++c) {
        const std::size_t lo = static_cast<std::size_t>(c), hi = lo + 3;
        if (!(p[c] - reach > b[lo] - halo && p[c] + reach < b[hi] + halo)) return std::nullopt;
      }
    }
  }
  // The normals' rows: the tile's points and the halo points the fits name; the others empty.
  Neighborhoods& normal_rows = lists.normals;
  normal_rows.stride = m;
  normal_rows.eps = inf;
  normal_rows.counts.assign(n, 0);
  normal_rows.indices.assign(n * static_cast<std::size_t>(m), 0);
  const auto put = [&](std::span<const Index> row, Index i) {
    const std::size_t count = std::min(row.size(), static_cast<std::size_t>(m));
    std::copy(row.begin(), row.begin() + static_cast<std::ptrdiff_t>(count),
              normal_rows.indices.begin() + static_cast<std::ptrdiff_t>(i * static_cast<std::size_t>(m)));
    normal_rows.counts[i] = static_cast<std::uint16_t>(count);
  };
  for (std::size_t r = 0; r < lists.fits.size(); ++r) put(lists.fits.of(r), local.queries[r]);
  for (std::size_t r = 0; r < near.size(); ++r) put(near.of(r), halo_queries[r]);
  lists.near_bytes = bytes(near.indices) + bytes(near.counts) + bytes(halo_queries) + 2 * n;
  return lists;
}

void Run::finish_tile(std::size_t t, const QuadricProjectionParams& q, std::vector<Vec3>& result) {
  // One pass of finish_with_quadrics for tile t's points, from the positions in
  // neighbor_source_: into `result`, in row order.
  for (double halo = knn_first_halo(t, q.k);; halo *= 2.0) {
    const LocalSet local = gather_local(t, halo);
    const std::optional<FinishLists> lists = finish_lists(t, halo, local, q);
    // The cell grids held about 48 bytes a point while they searched.
    const std::uint64_t searched = local.bytes() + local.positions.size() * 50;
    if (!lists) {
      account(searched);
      continue;
    }
    const std::vector<Vec3> normals = neighbourhood_normals(local.positions, lists->normals, q);
    result.resize(local.queries.size());
    project_rows_to_quadrics(local.positions, normals, lists->fits, local.queries, q, result);
    largest_local_ = std::max<std::uint64_t>(largest_local_, local.positions.size());
    account(searched + lists->bytes() + bytes(normals) + bytes(result));
    return;
  }
}

bool Run::run_finish(OutOfCoreReport& report) {
  // The passes of finish_with_quadrics after the last step, each from the last one's
  // positions into the other buffer and committed like a step. False when stopped
  // (OutOfCoreOptions::stop_after_finish_passes).
  if (!options_.quadric_finish) return true;
  const QuadricProjectionParams& q = *options_.quadric_finish;
  int pass = static_cast<int>(state_[kFinishPasses]);
  report.finish_passes = pass;
  if (pass >= q.passes) return true;
  const auto t0 = Clock::now();
  // The flow's lists stay on file for the attributes; their memory goes to the wider halos.
  cache_.assign(tiles_.size(), {});
  cache_bytes_ = 0;
  const std::uint64_t writes = tiles_to_write();
  std::vector<Vec3> result;
  int passes_here = 0;
  for (; pass < q.passes; ++pass) {
    if (pass == 0 && ranks_->rank() == 0) file().dataset(kStopLambda).write_rows(0, 1, &stop_lambda_);
    // The halos are found around the tiles' bounds in the positions the pass starts from.
    neighbor_source_ = current_source();
    measure_bounds();
    h5::Dataset target = file().dataset(positions_buffer(target_buffer()));
    for (std::size_t t = first_tile_; t < end_tile_; ++t) {
      const std::uint64_t rows = tiles_.rows(t);
      if (rows == 0) continue;
      finish_tile(t, q, result);
      target.write_rows(tiles_.offsets[t], rows, result.data()->data(), h5::Transfer::Collective);
      progress("finish", t + 1 - first_tile_, end_tile_ - first_tile_);
    }
    // Collective writes: as many per rank as the rank with the most tiles.
    for (std::uint64_t w = my_tiles(); w < writes; ++w) target.write_rows<double>(0, 0, nullptr, h5::Transfer::Collective);
    state_[kStepBuffer] = target_code(false);
    state_[kFinishPasses] = pass + 1;
    commit_state();
    report.finish_passes = pass + 1;
    ++passes_here;
    if (options_.stop_after_finish_passes >= 0 && passes_here >= options_.stop_after_finish_passes) {
      report.seconds_finish += seconds_since(t0);
      return false;
    }
  }
  report.seconds_finish += seconds_since(t0);
  return true;
}

// ---- attributes and the end ---------------------------------------------------------------------

std::size_t Run::write_attributes(double lambda) {
  const std::string source_path = current_source();
  const h5::Dataset source = file().dataset(source_path);
  // compute_attributes orients normals away from the centre of the bounding box.
  // Each rank bounds its own rows; the box of the cloud is the maximum over the ranks of
  // (-min, max).
  Eigen::AlignedBox3d box;
  std::vector<Vec3> block;
  for (std::uint64_t first = my_first_row(); first < my_end_row(); first += kScanBlock) {
    const std::uint64_t count = std::min(kScanBlock, my_end_row() - first);
    block.resize(count);
    source.read_rows(first, count, block.data()->data());
    for (const Vec3& p : block) box.extend(p);
  }
  if (ranks_->size() > 1) {
    std::array<double, 6> extent = {-box.min().x(), -box.min().y(), -box.min().z(),
                                    box.max().x(),  box.max().y(),  box.max().z()};
    ranks_->max(extent);
    box = Eigen::AlignedBox3d(Vec3(-extent[0], -extent[1], -extent[2]), Vec3(extent[3], extent[4], extent[5]));
  }
  const std::string a = layout::run_attributes;
  h5::Dataset normal = file().dataset(a + "/normal"), d1 = file().dataset(a + "/d1"), d2 = file().dataset(a + "/d2");
  h5::Dataset k1 = file().dataset(a + "/k1"), k2 = file().dataset(a + "/k2");
  h5::Dataset mean = file().dataset(a + "/mean_curvature"), lap = file().dataset(a + "/laplacian_norm");
  h5::Dataset feature = file().dataset(a + "/feature_class");
  std::vector<Vec3> local, vn, vd1, vd2;
  std::vector<double> vk1, vk2, vmean, vlap;
  std::vector<std::uint8_t> vfeature;
  Neighborhoods extended;
  std::size_t degenerate = 0;
  const std::uint64_t writes = tiles_to_write();
  constexpr h5::Transfer together = h5::Transfer::Collective;
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t rows = tiles_.rows(t), begin = tiles_.offsets[t];
    if (rows == 0) continue;
    const std::shared_ptr<const TileNeighbors> lists = neighbors_of(t);
    const TileNeighbors& nb = *lists;
    const bool cached = caching_ && cache_[t] == lists;
    read_tile_positions(t, nb, source, local, vn);  // vn: the rows in row order, until it is written below
    // compute_attributes itself on the tile: the halo rows get no neighbours (they are
    // evaluated elsewhere), and two extra points at the corners of the whole cloud's bounding
    // box make its centre, which orients the normals, the in-core one.
    const std::size_t extra = local.size() - rows + 2;
    local.push_back(box.min());
    local.push_back(box.max());
    extended.stride = nb.local.stride;
    extended.eps = nb.local.eps;
    extended.indices = nb.local.indices;
    extended.indices.resize(local.size() * static_cast<std::size_t>(extended.stride), 0);
    extended.counts = nb.local.counts;
    extended.counts.resize(local.size(), 0);
    const PointAttributes pa = compute_attributes(local, extended, params_.flow, lambda);
    degenerate += pa.degenerate - extra;
    // Back from the lists' order to row order.
    nb.to_rows(pa.normal, vn, rows);
    nb.to_rows(pa.d1, vd1, rows);
    nb.to_rows(pa.d2, vd2, rows);
    nb.to_rows(pa.k1, vk1, rows);
    nb.to_rows(pa.k2, vk2, rows);
    nb.to_rows(pa.mean_curvature, vmean, rows);
    nb.to_rows(pa.laplacian_norm, vlap, rows);
    nb.to_rows(pa.feature, vfeature, rows);
    normal.write_rows(begin, rows, vn.data()->data(), together);
    d1.write_rows(begin, rows, vd1.data()->data(), together);
    d2.write_rows(begin, rows, vd2.data()->data(), together);
    k1.write_rows(begin, rows, vk1.data(), together);
    k2.write_rows(begin, rows, vk2.data(), together);
    mean.write_rows(begin, rows, vmean.data(), together);
    lap.write_rows(begin, rows, vlap.data(), together);
    feature.write_rows(begin, rows, vfeature.data(), together);
    account(bytes(local) + bytes(extended.indices) + bytes(extended.counts) +
            pa.normal.size() * (9 * sizeof(double) + 4 * sizeof(double) + 1) + 3 * bytes(vn) + 4 * bytes(vk1) +
            bytes(vfeature) + (cached ? 0 : nb.bytes()));
    progress("attributes", t + 1 - first_tile_, end_tile_ - first_tile_);
  }
  for (std::uint64_t w = my_tiles(); w < writes; ++w) {
    for (h5::Dataset* d : {&normal, &d1, &d2, &k1, &k2, &mean, &lap}) d->write_rows<double>(0, 0, nullptr, together);
    feature.write_rows<std::uint8_t>(0, 0, nullptr, together);
  }
  return static_cast<std::size_t>(ranks_->sum(degenerate));
}

void Run::finish(std::size_t attributes_degenerate, double lambda) {
  // Rank 0 alone from here (release()): attributes are metadata.
  if (options_.attributes) {
    file().set_attribute(layout::run_attributes, "degenerate", static_cast<std::int64_t>(attributes_degenerate));
    file().set_attribute(layout::run_attributes, "lambda", lambda);
  }
  file().set_attribute(layout::run, "result_positions", current_source());
  file().set_attribute(layout::run, "eps", eps_);
  state_[kFinished] = 1;
  commit_state();
  file_.reset();
  std::error_code ec;
  fs::rename(partial_name(output_), output_, ec);
  if (ec) throw io::IoError(output_.string() + ": cannot rename the finished run into place: " + ec.message());
}

OutOfCoreReport Run::run() {
  params_.validate();
  if (options_.quadric_finish) options_.quadric_finish->validate();
  require(options_.memory_budget > 0, "the memory budget must be positive");
  require(options_.temporal_block >= 1, "the temporal block must be at least 1 step");
  require(options_.temporal_block == 1 || !(auto_lambda_on() && params_.lambda_every_step),
          "temporal blocks (--temporal-block) need a fixed lambda or one measured once (--lambda-schedule "
          "once): the automatic lambda of every step is measured on the whole cloud between steps");
  io::require_distinct(input_path_, output_);
  io::require_distinct(input_path_, partial_name(output_));
  OutOfCoreReport report;
  read_input_tables();
  if (params_.neighbors.k == 0) {
    // The automatic k, measured on the input's positions (as smooth() does), before the run
    // file is created (its lists have k columns), also on --resume. Every rank reads the input.
    file_.emplace(h5::File::open(input_path_, false));
    balance(false);
    params_.neighbors.k = resolve_k_tiled();
    file_.reset();
  }
  report.k = k();
  open_or_create();
  share();
  report.points = n_;
  report.tiles = tiles_.size();
  auto t0 = Clock::now();
  balance(false);  // by points: the halos are not known yet
  if (state_[kNeighborsDone] == 0) {
    if (!options_.neighbor_reference.empty()) {
      // The first lists from the reference's positions, with halos around its tiles' bounds.
      load_reference();
      neighbor_source_ = kReferencePositions;
      measure_bounds();
    }
    build_neighbors(0);
  }
  else file().dataset(layout::run_eps).read_rows(0, 1, &eps_);
  report.eps = eps_;
  balance(true);
  report.halo_points = halo_points_;
  if (auto_lambda_on()) prepare_lambda_sample();
  report.seconds_neighbors = seconds_since(t0);
  report.steps = static_cast<int>(state_[kCompletedSteps]);
  const bool steps_done = run_steps(report);
  report.positions_held = holding_;
  release_positions();  // the finish and the attributes need the room
  release_scratch();
  const bool finish_done = steps_done && run_finish(report);
  if (!finish_done) {
    report.neighbors_cached = caching_ && !ran_blocks_;
    report.tiles_in_flight = static_cast<int>(std::max(slots_, most_in_flight_));
    report.peak_accounted_bytes = peak_;
    report.largest_tile_with_halo = largest_local_;
    file_.reset();
    return report;
  }
  // The threshold of the last step (or of the input when there are no steps).
  double lambda = params_.flow.lambda;
  report.steps = final_steps_;
  if (final_steps_ > 0) {
    double entry[2];
    file().dataset(layout::run_step_log).read_rows(static_cast<std::uint64_t>(final_steps_ - 1), 1, entry);
    // Stopped early: smooth() reports the threshold measured on the final positions.
    lambda = final_steps_ < params_.steps ? stop_lambda_ : entry[0];
    report.degenerate = static_cast<std::size_t>(entry[1]);
  } else if (auto_lambda_on()) {
    load_sample_positions(file().dataset(layout::positions));
    lambda = sample_lambda();
  }
  report.lambda = lambda;
  t0 = Clock::now();
  const std::size_t attributes_degenerate = options_.attributes ? write_attributes(lambda) : 0;
  report.seconds_attributes = seconds_since(t0);
  release();
  if (ranks_->rank() == 0) finish(attributes_degenerate, lambda);
  ranks_->barrier();  // the run is in place when any rank returns
  report.finished = true;
  report.neighbors_cached = caching_ && !ran_blocks_;
  report.tiles_in_flight = static_cast<int>(std::max(slots_, most_in_flight_));
  report.peak_accounted_bytes = peak_;
  report.largest_tile_with_halo = largest_local_;
  return report;
}

}  // namespace

std::string size_text(std::uint64_t bytes, bool up) {
  const std::uint64_t unit = bytes < (std::uint64_t{1} << 20) ? 10 : 20;
  const std::uint64_t n = (bytes >> unit) + (up && (bytes & ((std::uint64_t{1} << unit) - 1)) != 0 ? 1 : 0);
  return std::to_string(n) + (unit == 10 ? " KiB" : " MiB");
}

fs::path partial_name(const fs::path& output) {
  fs::path p = output;
  p += ".partial";
  return p;
}

OutOfCoreReport smooth_out_of_core(const fs::path& input, const fs::path& output, const SmoothParams& params,
                                   const OutOfCoreOptions& options) {
  Run run(input, output, params, options);
  return run.run();
}

}  // namespace pointfair::tiles
