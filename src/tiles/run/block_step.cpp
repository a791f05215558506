// A step or temporal block over each tile's ring closure (BlockSlot): h steps per load of a
// tile and its h-ring (2 h-ring when compensated) closure, for temporal blocks
// (OutOfCoreOptions::temporal_block), compensated steps whose positions are not held, and
// plain streamed steps as blocks of one step (choose_step_blocks). The block lists come from
// their scratch where it was made, the rings' positions from the ring scratch where it holds
// the source's.
#include "run.hpp"

namespace pointfair::tiles::detail {

PipelineStages Run::block_stages(StepPlan& plan, StepWork& work, OutOfCoreReport& report, Clock::time_point& t0) {
  const int h = plan.h;
  {  // the block lists of this depth, made once: part of building the lists, as prepare_lists
    // (the first block at most reads them back; the blocks after it are no deeper until the
    // next rebuild)
    const auto tp = Clock::now();
    prepare_block_lists(block_depth(h));
    if (work.block_slots.size() < slots_) {
      work.slot_count = static_cast<std::size_t>(slots_);
      work.block_slots.resize(work.slot_count);
    }
    report.seconds_neighbors += seconds_since(tp);
    t0 += Clock::now() - tp;
  }
  plan.scratch_block = ring_scratch_ && block_depth(h) <= block_lists_depth_;
  ran_blocks_ = true;
  if (step_blocks_) report.step_blocks = true;
  int ring_from = ring_scratch_ ? buffer_holding_source(ring_holds_) : -1;
  if (plan.scratch_block && ring_from < 0) {
    // The first block of a call or after a rebuild: the rings' positions into the buffer
    // this block does not write.
    ring_from = 1 - plan.written_halos;
    fill_ring_scratch(*plan.source, ring_from);
  }
  if (ring_scratch_) ring_holds_[static_cast<std::size_t>(plan.written_halos)].clear();
  // Blocks whose lists and rings come from the scratch write their tiles in Morton order
  // (BlockSlot::order) where the next block reads them so too (its lists come from the
  // scratch: not the last block, nor one before a rebuild); nothing is moved into row
  // order and back.
  const bool listed_in = source_in_list_order();
  const int step = plan.step;
  plan.block_list_order = plan.scratch_block && local_order_ && !plan.gather_sample && step + h < params_.steps &&
                          !rebuild_due(step + h) && block_depth(block_length(step + h)) <= block_lists_depth_;
  PipelineStages stages;
  stages.read = [this, &plan, &work, ring_from, listed_in](std::size_t item, std::size_t slot) {
    BlockSlot& b = work.block_slots[slot];
    read_block(work.tiles[item], block_depth(plan.h), *plan.source, b, ring_from, listed_in);
    b.write_listed = plan.block_list_order;
    read_moves(plan, b.tile, b.order, b.moves);
    // The plain updates of a compensated step, counted with the rest of the block.
    if (compensated()) b.updated.resize(b.cur.size());
    largest_local_ = std::max<std::uint64_t>(largest_local_, b.cur.size());
    b.accounted = b.bytes();
    account(block_slots_bytes(work) + bytes(work.identity));
  };
  stages.compute = [this, &plan, &work](std::size_t slot) {
    work.block_slots[slot].compute(params_.flow, plan.lambda, params_.shrink_compensation, plan.momentum,
                                   plan.writes_moves);
  };
  stages.write = [this, &plan, &work](std::size_t, std::size_t slot) {
    BlockSlot& b = work.block_slots[slot];
    const std::uint64_t begin = tiles_.offsets[b.tile], rows = tiles_.rows(b.tile);
    const Vec3* const result = b.tile_rows();
    plan.target->write_rows(begin, rows, result->data(), h5::Transfer::Collective);
    write_moves(plan, b.tile, b.order, b.moves);
    file().start_writeback();
    if (plan.scratch_block) ring_scratch_->write(plan.written_halos, b.tile, b.cur.data());
    b.mapped = {};  // the tile's lists, mapped: unmapped as soon as it is done
    b.accounted = b.bytes();
    for (int j = 0; j < plan.h; ++j) {
      plan.block_degenerate[static_cast<std::size_t>(j)] += b.degenerate[static_cast<std::size_t>(j)];
    }
    // One step a block (with a lambda of every step, a block is one step).
    if (plan.gather_sample) gather_sample_rows(begin, rows, [&](std::uint64_t r) { return result[r]; });
  };
  return stages;
}

}  // namespace pointfair::tiles::detail
