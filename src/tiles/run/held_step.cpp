// A step over positions held in memory (the strategy while every tile's lists and two copies
// of the positions fit in the budget): holding them (hold_positions, load_held), each tile's
// halo copied from the tiles that hold its points, and the step's stages.
#include "run.hpp"

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
  // With momentum, the last moves of every tile in flight (TileMoves: two copies of its rows).
  const std::uint64_t moves = momentum_on() ? 2 * (my_end_row() - my_first_row()) * sizeof(Vec3) : 0;
  const bool index_sample = ranks_->size() == 1 && auto_lambda_on() && params_.lambda_every_step;
  const std::uint64_t need = copies * total * sizeof(Vec3) + halo_total * sizeof(std::uint64_t) + bytes(base) +
                             (my_end_row() - my_first_row()) * sizeof(Index) +  // the inverse orders below
                             (index_sample ? gather_rows_.size() * sizeof(std::uint64_t) : 0) + moves;
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

PipelineStages Run::held_stages(StepPlan& plan, StepWork& work) {
  // Positions held in memory: the source is held_[held_cur_] (read from the file before
  // the first step, load_held), each tile's step goes into held_[1 - held_cur_] in the
  // lists' order, and from there into the file: as it is on a list_order_step, else
  // through the slot's `next` in row order.
  PipelineStages stages;
  stages.read = [this, &plan, &work](std::size_t item, std::size_t slot) {
    StepSlot& s = work.slots[slot];
    s.tile = work.tiles[item];
    s.nb = neighbors_of(s.tile);
    const std::uint64_t rows = tiles_.rows(s.tile);
    const std::vector<std::uint64_t>& from = held_halo_[s.tile];
    if (plan.list_order_step) free_vector(s.next);  // the step is written from the held buffer
    else s.next.resize(rows);
    read_moves(plan, s.tile, s.nb->order, s.moves);
    largest_local_ = std::max<std::uint64_t>(largest_local_, rows + from.size());
    account(step_slots_bytes(work));
  };
  // The step's rows of a tile in file order (`next`), from the held buffer (Morton order
  // within the tile when the lists are). A scattered copy: with one compute thread the
  // writing thread, otherwise idle, does it; with more the compute threads share it, since
  // on the writing thread it cost about as much as half the isotropic step (1M points,
  // 2 threads: 16.3M point-steps/s out of core with it there, 19.1M without).
  const bool scatter_on_compute = thread_count() > 1;
  const auto to_file_order = [this](StepSlot& s) {
    const std::uint64_t rows = tiles_.rows(s.tile);
    const Vec3* const out = held_[static_cast<std::size_t>(1 - held_cur_)].data() + held_base_[s.tile];
    const std::vector<Index>& order = s.nb->order;
    parallel_for(rows, [&](std::size_t b, std::size_t e) {
      if (order.empty()) std::copy(out + b, out + e, s.next.begin() + static_cast<std::ptrdiff_t>(b));
      else
        for (std::size_t r = b; r < e; ++r) s.next[order[r]] = out[r];
    }, 8192);
  };
  stages.compute = [this, &plan, &work, to_file_order, scatter_on_compute](std::size_t slot) {
    StepSlot& s = work.slots[slot];
    const std::uint64_t rows = tiles_.rows(s.tile), base = held_base_[s.tile];
    std::vector<Vec3>& cur = held_[static_cast<std::size_t>(held_cur_)];
    const std::vector<std::uint64_t>& from = held_halo_[s.tile];
    const std::span<const Vec3> local(cur.data() + base, rows + from.size());
    const std::span<Vec3> out(held_[static_cast<std::size_t>(1 - held_cur_)].data() + base, rows);
    const std::span<const Index> identity(work.identity.data(), rows);
    if (compensated()) {
      if (!plan.updated_ready) held_plain_updates(plan, work);
      plan.updated_ready = true;
      s.stats = plan.plain_stats[s.tile];
      compensate_updates(local, std::span<const Vec3>(held_updated_.data() + base, rows + from.size()), s.nb->local,
                         identity, params_.shrink_compensation, s.moves.momentum(plan.momentum), out);
    } else {
      // The halo from the tiles holding it, here on the compute threads (step-n positions:
      // nothing writes them now; each tile's halo has its own place in the held buffer).
      copy_halo(cur, s.tile);
      s.stats = euler_step(local, s.nb->local, identity, params_.flow, plan.lambda, out);
      if (plan.momentum > 0.0) add_momentum(local, out, identity, s.moves.momentum(plan.momentum), out);
    }
    if (plan.writes_moves) s.moves.keep(local.first(rows), out);
    if (scatter_on_compute && !plan.list_order_step) to_file_order(s);
  };
  stages.write = [this, &plan, &work, to_file_order, scatter_on_compute](std::size_t, std::size_t slot) {
    StepSlot& s = work.slots[slot];
    const std::uint64_t begin = tiles_.offsets[s.tile], rows = tiles_.rows(s.tile);
    plan.degenerate += s.stats.degenerate;
    const Vec3* const out = held_[static_cast<std::size_t>(1 - held_cur_)].data() + held_base_[s.tile];
    if (plan.lag_writes) {
      // written by the next step (StepWork::Lagged)
    } else if (plan.list_order_step) {
      plan.target->write_rows(begin, rows, out->data(), h5::Transfer::Collective);
    } else {
      if (!scatter_on_compute) to_file_order(s);
      plan.target->write_rows(begin, rows, s.next.data()->data(), h5::Transfer::Collective);
    }
    write_moves(plan, s.tile, s.nb->order, s.moves);
    free_vector(s.moves.by_row);  // counted as the tile's rows (hold_positions), not as a slot's
    free_vector(s.moves.listed);
    if (!plan.lag_writes) file().start_writeback();
    if (plan.gather_sample && held_sample_.empty())
      gather_sample_rows(begin, rows, [&](std::uint64_t r) {
        return plan.list_order_step ? out[held_slot_[begin + r - my_first_row()]] : s.next[r];
      });
    s.nb.reset();
  };
  return stages;
}

void Run::held_plain_updates(StepPlan& plan, const StepWork& work) {
  // A compensated step with its positions held (shrink_compensation.hpp), in two passes: the
  // plain step's updates of every tile into held_updated_ (with the first tile's compute),
  // then their halos copied in; each tile's compute then compensates from both.
  std::vector<Vec3>& cur = held_[static_cast<std::size_t>(held_cur_)];
  for (const std::size_t t : work.tiles) {
    const std::uint64_t rows = tiles_.rows(t), base = held_base_[t];
    copy_halo(cur, t);
    const std::span<const Vec3> local(cur.data() + base, rows + held_halo_[t].size());
    const std::span<Vec3> updates(held_updated_.data() + base, rows);
    plan.plain_stats[t] = euler_step(local, cache_[t]->local, std::span<const Index>(work.identity.data(), rows),
                                     params_.flow, plan.lambda, updates);
    to_updates(local, updates);
  }
  // The halos' updates (their home tiles' own rows, from the same positions).
  for (const std::size_t t : work.tiles) copy_halo(held_updated_, t);
}

}  // namespace pointfair::tiles::detail
