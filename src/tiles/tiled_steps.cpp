// The steps: positions held in memory or streamed, single steps and blocks, in a pipeline.
#include "tiled_run.hpp"

#include <cassert>

namespace pointfair::tiles::detail {

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
  // A lambda of every step from a sample that is not gathered is read from the run file,
  // which held steps write late or in list order.
  able = able && (sample_gathered_ || !(auto_lambda_on() && params_.lambda_every_step));
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
  // Collective writes: as many per rank as the rank with the most tiles. Counted before any
  // write, as every rank calls the count (an MPI reduction) at the same point: a rank without
  // tiles counted after its (no) writes while a rank with a tile was inside its first
  // collective write, and both waited for ever (fewer tiles than ranks).
  const std::uint64_t writes = tiles_to_write();
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
  for (std::uint64_t w = my_tiles(); w < writes; ++w) target.write_rows<double>(0, 0, nullptr, h5::Transfer::Collective);
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
      if (const std::optional<StopReason> reason = stop_reason(params_, lambdas)) {
        report.stop_reason = *reason;
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
    // Not where the next step's lambda is read from the run file in row order (a sample that
    // is not gathered).
    const bool streamed_list_order = halos != nullptr && streamed_lists_ordered() && step + 1 < params_.steps &&
                                     !rebuild_due(step + 1) && (sample_gathered_ || !gather_sample);
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
    assert(!source_listed || halos_from >= 0);  // a source in list order comes with its halos
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
    // A sample that is not gathered: the next lambda reads this step's positions, written in
    // row order.
    if (gather_sample && !sample_gathered_) sample_source_ = target_name;
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
  report.stop_reason = StopReason::StepLimit;
  return true;
}

}  // namespace pointfair::tiles::detail
