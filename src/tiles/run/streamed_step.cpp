// A step that streams each tile and its halo from the run file (the strategy when the
// positions are not held in memory and the steps are not blocks): each tile's halo from the
// halo scratch where it holds the source's (the previous step wrote it), else from the run
// file; the step writes the target's.
#include "run.hpp"

#include <cassert>

namespace pointfair::tiles::detail {

PipelineStages Run::streamed_stages(StepPlan& plan, StepWork& work) {
  PipelineStages stages;
  HaloScratch* const halos = plan.halos;
  const int halos_from = halos != nullptr ? buffer_holding_source(scratch_holds_) : -1;
  if (halos != nullptr) scratch_holds_[static_cast<std::size_t>(plan.written_halos)].clear();
  // A source in list order was written by the previous step of this call, with the halos.
  const bool source_listed = source_in_list_order();
  assert(!source_listed || halos_from >= 0);  // a source in list order comes with its halos
  stages.read = [this, &plan, &work, halos_from, source_listed](std::size_t item, std::size_t slot) {
    StepSlot& s = work.slots[slot];
    s.tile = work.tiles[item];
    // The slot's lists are reused from tile to tile unless they are the cache's.
    if (!s.own) s.own = std::make_shared<TileNeighbors>();
    s.nb = neighbors_of(s.tile, s.own);
    s.read_in_list_order = source_listed && !s.nb->order.empty();
    read_tile_positions(s.tile, *s.nb, *plan.source, s.local, s.next, false, halos_from, s.read_in_list_order);
    rows_read_ += s.local.size();
    s.next.resize(tiles_.rows(s.tile));
    read_moves(plan, s.tile, s.nb->order, s.moves);
    // Sized here, not by the compute: this thread reads every slot's vectors (step_slots_bytes).
    if (plan.streamed_list_order && plan.gather_sample && !s.nb->order.empty()) s.slot_of.resize(tiles_.rows(s.tile));
    largest_local_ = std::max<std::uint64_t>(largest_local_, s.local.size());
    account(step_slots_bytes(work));
  };
  stages.compute = [this, &plan, &work](std::size_t slot) {
    StepSlot& s = work.slots[slot];
    const std::size_t rows = s.next.size();
    const std::vector<Index>& order = s.nb->order;
    if (!order.empty() && !s.read_in_list_order) s.nb->to_local(s.next, s.local, rows);
    const std::span<const Index> identity(work.identity.data(), rows);
    s.stats = euler_step(s.local, s.nb->local, identity, params_.flow, plan.lambda, s.next);
    if (plan.momentum > 0.0) add_momentum(s.local, s.next, identity, s.moves.momentum(plan.momentum), s.next);
    if (plan.writes_moves) s.moves.keep(std::span<const Vec3>(s.local).first(rows), s.next);
    if (order.empty()) return;
    if (!plan.streamed_list_order) {
      s.nb->to_rows(s.next, s.local, rows);
    } else if (plan.gather_sample) {
      parallel_for(rows, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) s.slot_of[order[i]] = static_cast<Index>(i);
      }, 8192);
    }
  };
  stages.write = [this, &plan, &work, halos](std::size_t, std::size_t slot) {
    StepSlot& s = work.slots[slot];
    const std::uint64_t begin = tiles_.offsets[s.tile], rows = tiles_.rows(s.tile);
    plan.degenerate += s.stats.degenerate;
    // `next`: the step in the lists' order (row order for a tile without one).
    const bool listed = plan.streamed_list_order && !s.nb->order.empty();
    const std::vector<Vec3>& result = listed ? s.next : s.result();
    plan.target->write_rows(begin, rows, result.data()->data(), h5::Transfer::Collective);
    write_moves(plan, s.tile, s.nb->order, s.moves);
    file().start_writeback();
    if (halos != nullptr) halos->write(plan.written_halos, s.tile, s.next.data());
    if (plan.gather_sample)
      gather_sample_rows(begin, rows, [&](std::uint64_t r) { return result[listed ? s.slot_of[r] : r]; });
    s.nb.reset();  // lists that are not cached are freed with their tile
  };
  return stages;
}

}  // namespace pointfair::tiles::detail
