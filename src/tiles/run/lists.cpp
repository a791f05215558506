// What the steps read: each tile's lists, the halo scratch, the block lists and their scratch.
#include "run.hpp"

#include <cassert>

namespace pointfair::tiles::detail {

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
  int h = std::min(temporal_block(), params_.steps - step);
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
  [[maybe_unused]] const unsigned char* const end = p + size;
  const auto next = [&](std::uint64_t bytes) {
    assert(static_cast<std::uint64_t>(end - p) >= padded(bytes));  // the record as written by this run
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
  assert(header[0] == d);
  s.tile = t;
  copy(s.level_end, d + 1);
  assert(header[1] == 0 || header[1] == s.level_end[0]);
  const std::size_t rings = s.level_end[d] - s.level_end[0], listed = s.level_end[d - 1];
  copy(s.sorted_rows, rings);
  copy(s.sorted_local, rings);
  const auto* counts = reinterpret_cast<const std::uint16_t*>(next(listed * sizeof(std::uint16_t)));
  const auto* indices = reinterpret_cast<const Index*>(next(listed * kk * sizeof(Index)));
  copy(s.order, header[1]);
  assert(p == end);
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
  assert(!listed || (cached && ring_buffer >= 0));  // list order needs the lists and the rings
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
  const std::uint64_t d = blocks() ? static_cast<std::uint64_t>(block_depth(temporal_block())) : 0;
  const std::uint64_t list_bytes = static_cast<std::uint64_t>(k()) * sizeof(Index) + sizeof(std::uint16_t);
  const std::uint64_t per_local = (compensated() ? 3 : 2) * sizeof(Vec3) + 2 * sizeof(std::uint64_t) + sizeof(Index);
  const std::uint64_t per_listed = sizeof(Vec3) + sizeof(Index) + 2 * list_bytes;
  const std::uint64_t per_ring = RowMap::kBytesPerRow;  // a ring row's entry in BlockSlot::ring_local
  // With momentum, a tile's last moves as read and in the order of its positions.
  const std::uint64_t per_moved = momentum_on() ? 2 * sizeof(Vec3) : 0;
  slot_estimate_ = 0;
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t rows = tiles_.rows(t), h = t < halo.size() ? halo[t] : rows;
    slot_estimate_ = std::max(slot_estimate_, rows * per_moved +
                                                  (d > 0 ? (rows + d * h) * per_local + (rows + (d - 1) * h) * per_listed + d * h * per_ring
                                                         : rows * per_row + h * (sizeof(Vec3) + sizeof(std::uint64_t))));
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

}  // namespace pointfair::tiles::detail
