// The step loop every strategy shares: where the steps start (a resumed run), the lambda and
// the automatic stop, the rebuilds, the choice of strategy (positions held in memory,
// streamed tile by tile, or blocks over a tile's ring closure: held_step.cpp,
// streamed_step.cpp, block_step.cpp), and the commit of every step.
#include "run.hpp"

namespace pointfair::tiles::detail {

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
  double lambda = lambda_at_start(start, every_step);
  if (every_step) load_sample_positions(file().dataset(current_source()));
  StepWork work = start_step_work(report);
  int committed_here = 0;
  // The automatic stop and the momentum look at the lambdas of every step so far (stop_reason,
  // momentum_of_step): those of the steps before `start` from the step log, so that a resumed
  // run stops and moves where an uninterrupted one does.
  std::vector<double> lambdas = logged_lambdas(start);
  for (int step = start; step < params_.steps;) {
    if (rebuild_due(step) && state_[kNeighborsStep] != step) {
      finish_commit_timed(work, report);
      rebuild_for(step, work, report, lambda, every_step);
    }
    auto t0 = Clock::now();
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
    const bool lambda_rose = note_lambda(step, lambda, lambdas);
    if (stops_automatically()) {
      if (const std::optional<StopReason> reason = stop_reason(params_, lambdas)) {
        report.stop_reason = *reason;
        report.seconds_steps += seconds_since(t0);
        finish_commit_timed(work, report);
        final_steps_ = step;
        stop_lambda_ = lambda;
        return true;
      }
    }
    StepPlan plan = plan_step(step, lambda, committed_here, every_step);
    plan_momentum(plan, lambda_rose, lambdas, report);
    PipelineStages stages = blocks()   ? block_stages(plan, work, report, t0)
                            : holding_ ? held_stages(plan, work)
                                       : streamed_stages(plan, work);
    run_step_pipeline(plan, work, std::move(stages));
    const bool stopping = commit_step(plan, work, report, committed_here);
    step = plan.step + plan.h;
    report.seconds_steps += seconds_since(t0);
    if (stopping && step < params_.steps) return false;
  }
  finish_commit_timed(work, report);
  final_steps_ = params_.steps;
  report.stop_reason = StopReason::StepLimit;
  return true;
}

double Run::lambda_at_start(int start, bool every_step) {
  if (!auto_lambda_on() || every_step) return params_.flow.lambda;
  // The step whose positions the lists in force were built from (a rebuild at `start` itself
  // may not have happened yet: then the loop does it).
  const int built_at = static_cast<int>(state_[kNeighborsStep]);
  if (built_at > 0 && built_at < start) {
    // Measured once after the last rebuild, on positions that are gone: the step log has it.
    double entry[2];
    file().dataset(layout::run_step_log).read_rows(static_cast<std::uint64_t>(start - 1), 1, entry);
    return entry[0];
  }
  load_sample_positions(file().dataset(built_at == 0 ? step0_source() : current_source()));
  const double lambda = sample_lambda();
  free_vector(gather_positions_);
  return lambda;
}

std::vector<double> Run::logged_lambdas(int start) {
  std::vector<double> lambdas;
  if (start == 0) return lambdas;
  std::vector<double> entries(2 * static_cast<std::size_t>(start));
  file().dataset(layout::run_step_log).read_rows(0, static_cast<std::uint64_t>(start), entries.data());
  lambdas.push_back(entries[0]);
  for (int s = 1; s < start; ++s)
    if (params_.lambda_every_step && measures_lambda_before(params_, s))
      lambdas.push_back(entries[2 * static_cast<std::size_t>(s)]);
  return lambdas;
}

bool Run::note_lambda(int step, double lambda, std::vector<double>& lambdas) const {
  if (step == 0) {
    lambdas.assign(1, lambda);
    return false;
  }
  if (!params_.lambda_every_step || !measures_lambda_before(params_, step)) return false;
  const bool rose = lambda > lambdas.back();
  lambdas.push_back(lambda);
  return rose;
}

StepWork Run::start_step_work(OutOfCoreReport& report) {
  StepWork work;
  work.writes = tiles_to_write();
  work.identity.resize(max_tile_rows_);
  std::iota(work.identity.begin(), work.identity.end(), Index{0});
  for (std::size_t t = first_tile_; t < end_tile_; ++t)
    if (tiles_.rows(t) > 0) work.tiles.push_back(t);
  // The tiles of a step go through a bounded pipeline (pipeline.hpp): tile i+1 and its halo
  // are read while tile i is computed and tile i-1 written, all HDF5 calls on this thread.
  // Each slot holds one tile in flight; every slot's buffers count in the budget.
  work.slot_count = pipeline_slots(bytes(work.identity));
  // After the slots are sized: the lists are cached only next to room for the tiles in flight.
  prepare_lists(report);
  const auto th = Clock::now();
  hold_positions();
  choose_step_blocks();
  report.seconds_neighbors += seconds_since(th);
  // Positions held in list order, a slot holds no positions: then every tile of a step is in
  // flight at once, so that the worker never waits for this thread (the commit of the last
  // step, before the first write, mostly waits for the disk).
  work.slots.resize(std::max(work.slot_count, work.tiles.size()));
  // Temporal blocks (OutOfCoreOptions::temporal_block) and compensated steps: h steps per load
  // of a tile and its h-ring (2 h-ring) closure, in a pipeline of their own.
  work.block_slots.resize(blocks() ? work.slot_count : 0);
  return work;
}

void Run::rebuild_for(int step, StepWork& work, OutOfCoreReport& report, double& lambda, bool every_step) {
  const auto t0 = Clock::now();
  rebuild_neighbors(step);
  prepare_lists(report);
  hold_positions();
  choose_step_blocks();
  if (blocks() && work.block_slots.empty()) {
    // Compensated steps whose positions no longer fit once the lists are rebuilt, or plain
    // steps as blocks: blocks from here, with slots sized for them.
    work.slot_count = pipeline_slots(bytes(work.identity));
    work.block_slots.resize(work.slot_count);
  }
  ++report.rebuilds;
  if (auto_lambda_on() && !every_step) {
    lambda = sample_lambda();
    free_vector(gather_positions_);
  }
  report.seconds_neighbors += seconds_since(t0);
}

StepPlan Run::plan_step(int step, double lambda, int committed_here, bool every_step) {
  StepPlan plan;
  plan.step = step;
  plan.lambda = lambda;
  plan.source.emplace(file().dataset(current_source()));
  plan.target_name = positions_buffer(target_buffer());
  plan.target.emplace(file().dataset(plan.target_name));
  plan.h = block_length(step);
  const int h = plan.h;
  plan.gather_sample = every_step && step + h < params_.steps && measures_lambda_before(params_, step + h);
  plan.list_order_step = !blocks() && holding_ && held_list_order_ && step + 1 < params_.steps && !rebuild_due(step + 1);
  plan.lag_writes = plan.list_order_step && ranks_->size() == 1 && !compensated() &&
                    !(options_.stop_after_steps >= 0 && committed_here + h >= options_.stop_after_steps);
  plan.halos = !blocks() && !holding_ ? streamed_halos() : nullptr;
  // Not where the next step's lambda is read from the run file in row order (a sample that
  // is not gathered).
  plan.streamed_list_order = plan.halos != nullptr && streamed_lists_ordered() && step + 1 < params_.steps &&
                             !rebuild_due(step + 1) && (sample_gathered_ || !plan.gather_sample);
  plan.block_degenerate.assign(static_cast<std::size_t>(h), 0);
  plan.plain_stats.resize(compensated() ? tiles_.size() : 0);
  plan.written_halos = target_buffer();
  return plan;
}

void Run::run_step_pipeline(StepPlan& plan, StepWork& work, PipelineStages stages) {
  if (work.lagged.pending) {
    // The previous step's tiles, one as each of this step's after the first is read
    // (nothing is read from the file: the positions are held), so that they overlap the
    // computes from the first on; the last before this step's first write.
    stages.read = [this, &work, read = stages.read](std::size_t item, std::size_t slot) {
      write_lagged(work, item);
      read(item, slot);
    };
  }
  if (work.commit_pending || work.lagged.pending) {
    // The pending commit: before the first write (the worker computes the tiles read
    // meanwhile).
    stages.write = [this, &work, write = stages.write](std::size_t item, std::size_t slot) {
      finish_commit(work);
      write(item, slot);
    };
  }
  std::size_t in_flight = plan.list_order_step ? work.slots.size() : work.slot_count;
  if (holding_ && !blocks() && !plan.list_order_step) {
    // A held step in row order (the last, or one before a rebuild): a slot holds only its
    // tile's rows in file order (`next`), so as many as fit in the room kept for the slots
    // are in flight, and the computes need not wait for the previous step's commit.
    const std::uint64_t room = slots_room();
    const std::uint64_t per_slot = std::max<std::uint64_t>(1, max_tile_rows_ * sizeof(Vec3));
    in_flight = static_cast<std::size_t>(std::clamp<std::uint64_t>(room / per_slot, work.slot_count, work.slots.size()));
  }
  most_in_flight_ = std::max<std::uint64_t>(most_in_flight_, std::min(in_flight, work.tiles.size()));
  run_pipeline(work.tiles.size(), in_flight, stages);
  if (holding_) held_cur_ = 1 - held_cur_;
  if (holding_ && plan.gather_sample && !held_sample_.empty()) {
    const std::vector<Vec3>& now = held_[static_cast<std::size_t>(held_cur_)];
    parallel_for(held_sample_.size(), [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) gather_positions_[i] = now[held_sample_[i]];
    }, 4096);
  }
  // A sample that is not gathered: the next lambda reads this step's positions, written in
  // row order.
  if (plan.gather_sample && !sample_gathered_) sample_source_ = plan.target_name;
  if (plan.halos != nullptr) scratch_holds_[static_cast<std::size_t>(plan.written_halos)] = positions_buffer(plan.written_halos);
  if (plan.scratch_block) ring_holds_[static_cast<std::size_t>(plan.written_halos)] = positions_buffer(plan.written_halos);
  // Collective writes: as many per rank as the rank with the most tiles.
  for (std::uint64_t w = my_tiles(); w < work.writes; ++w) {
    plan.target->write_rows<double>(0, 0, nullptr, h5::Transfer::Collective);
    if (plan.writes_moves) plan.moves_target->write_rows<double>(0, 0, nullptr, h5::Transfer::Collective);
  }
  if (!blocks()) plan.block_degenerate[0] = plan.degenerate;
  if (plan.gather_sample && ranks_->size() > 1) {
    // Each rank updated the sample's positions in its own tiles: exchange them.
    const auto first = std::lower_bound(gather_rows_.begin(), gather_rows_.end(), my_first_row()) - gather_rows_.begin();
    const auto end = std::lower_bound(gather_rows_.begin(), gather_rows_.end(), my_end_row()) - gather_rows_.begin();
    std::fill(gather_positions_.begin(), gather_positions_.begin() + first, Vec3::Zero());
    std::fill(gather_positions_.begin() + end, gather_positions_.end(), Vec3::Zero());
    ranks_->merge(std::span<double>(gather_positions_.data()->data(), 3 * gather_positions_.size()));
  }
  h5::Dataset log = file().dataset(layout::run_step_log);
  for (int j = 0; j < plan.h; ++j) {
    plan.degenerate = static_cast<std::size_t>(ranks_->sum(plan.block_degenerate[static_cast<std::size_t>(j)]));
    const double entry[2] = {plan.lambda, static_cast<double>(plan.degenerate)};
    if (ranks_->rank() == 0) log.write_rows(static_cast<std::uint64_t>(plan.step + j), 1, entry);
  }
}

bool Run::commit_step(StepPlan& plan, StepWork& work, OutOfCoreReport& report, int& committed_here) {
  const int step = plan.step + plan.h;
  state_[kCompletedSteps] = step;
  state_[kStepBuffer] = target_code(plan.list_order_step || plan.streamed_list_order || plan.block_list_order);
  committed_here += plan.h;
  const bool stopping = options_.stop_after_steps >= 0 && committed_here >= options_.stop_after_steps;
  if (plan.lag_writes) {
    write_lagged(work, work.tiles.size());  // done by this step's reads already
    work.lagged = {true, held_cur_, plan.target_name, state_, 0};
  } else if (ranks_->size() == 1 && step < params_.steps && !stopping) {
    work.commit_pending = true;
  } else {
    commit_state();
    progress("step", static_cast<std::uint64_t>(step), static_cast<std::uint64_t>(params_.steps));
  }
  if (plan.halos != nullptr || plan.scratch_block) report.halo_scratch = true;
  report.steps = step;
  report.position_rows_read = rows_read_;
  report.list_rows_read = list_rows_read_;
  report.lambda = plan.lambda;
  report.eps = eps_;
  report.degenerate = plan.degenerate;
  return stopping;
}

void Run::write_lagged(StepWork& work, std::size_t end) {
  StepWork::Lagged& lagged = work.lagged;
  if (!lagged.pending) return;
  const std::vector<Vec3>& from = held_[static_cast<std::size_t>(lagged.buffer)];
  h5::Dataset target = file().dataset(lagged.target);
  for (; lagged.written < std::min(end, work.tiles.size()); ++lagged.written) {
    const std::size_t t = work.tiles[lagged.written];
    target.write_rows(tiles_.offsets[t], tiles_.rows(t), from[held_base_[t]].data());
    file().start_writeback();
  }
  if (lagged.written < work.tiles.size()) return;
  commit_state(lagged.record);
  lagged.pending = false;
  progress("step", static_cast<std::uint64_t>(lagged.record[kCompletedSteps]), static_cast<std::uint64_t>(params_.steps));
}

void Run::finish_commit(StepWork& work) {
  write_lagged(work, work.tiles.size());
  if (!work.commit_pending) return;
  commit_state();
  work.commit_pending = false;
  progress("step", static_cast<std::uint64_t>(state_[kCompletedSteps]), static_cast<std::uint64_t>(params_.steps));
}

void Run::finish_commit_timed(StepWork& work, OutOfCoreReport& report) {
  const auto tc = Clock::now();
  finish_commit(work);
  to_row_order();
  report.seconds_steps += seconds_since(tc);
}

std::uint64_t Run::step_slots_bytes(const StepWork& work) const {
  std::uint64_t total = bytes(work.identity);
  for (const StepSlot& s : work.slots) {
    total += bytes(s.local) + bytes(s.next) + bytes(s.slot_of) + (s.own ? s.own->bytes() : 0);
    // Held, the moves count with the positions (held_bytes_): every tile may be in flight.
    if (!holding_) total += s.moves.bytes();
    if (s.nb && s.nb != s.own && !(caching_ && cache_[s.tile] == s.nb)) total += s.nb->bytes();
  }
  return total;
}

std::uint64_t Run::block_slots_bytes(const StepWork& work) const {
  std::uint64_t total = 0;
  for (const BlockSlot& b : work.block_slots) total += b.accounted;
  return total;
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

}  // namespace pointfair::tiles::detail
