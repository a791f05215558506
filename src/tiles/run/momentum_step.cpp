// Momentum out of core (SmoothParams::momentum): the rules of momentum_of_step followed from
// the lambdas the step loop keeps (steps.cpp: logged_lambdas, note_lambda), and each tile's last
// moves read before its step and written after it. The moves live in the run file in row
// order, one buffer per step parity, so that every strategy (held, streamed, blocks) and
// every tiling reads the same moves and gives smooth()'s bits.
#include "run.hpp"

namespace pointfair::tiles::detail {

void Run::plan_momentum(StepPlan& plan, bool lambda_rose, std::span<const double> lambdas, OutOfCoreReport& report) {
  if (!momentum_on()) return;
  assert(plan.h == 1);  // block_length: one step a block with momentum
  const int step = plan.step;
  plan.momentum = momentum_of_step(params_, step, rebuild_due(step), lambda_rose, lambdas);
  if (lambda_rose && momentum_of_step(params_, step, rebuild_due(step), false, lambdas) > 0.0)
    ++report.momentum_restarts;
  // Whether the next step may have momentum: its lambda is not known yet (as if it did not
  // rise), nor, on step 0, the gate's (step 1's lambda).
  plan.writes_moves = step + 1 < params_.steps &&
                      (step == 0 ? !rebuild_due(1)
                                 : momentum_of_step(params_, step + 1, rebuild_due(step + 1), false, lambdas) > 0.0);
  if (plan.momentum > 0.0) plan.moves_source.emplace(file().dataset(moves_buffer(step)));
  if (plan.writes_moves) plan.moves_target.emplace(file().dataset(moves_buffer(step + 1)));
}

void Run::read_moves(const StepPlan& plan, std::size_t t, std::span<const Index> order, TileMoves& moves) const {
  // Sized here, on the thread that reads every slot's vectors (step_slots_bytes), for the
  // compute to fill (TileMoves::keep).
  const std::uint64_t rows = tiles_.rows(t);
  if (plan.momentum == 0.0) {
    moves.listed.resize(plan.writes_moves ? rows : 0);
    return;
  }
  moves.by_row.resize(rows);
  plan.moves_source->read_rows(tiles_.offsets[t], rows, moves.by_row.data()->data());
  for (std::uint64_t r = 0; r < rows; ++r)
    if (!moves.by_row[r].allFinite())
      file().fail(moves_buffer(plan.step), "row " + std::to_string(tiles_.offsets[t] + r) + " has a non-finite move");
  moves.to_listed(order);
}

void Run::write_moves(StepPlan& plan, std::size_t t, std::span<const Index> order, TileMoves& moves) {
  if (!plan.writes_moves) return;
  assert(moves.listed.size() == tiles_.rows(t));
  moves.to_rows(order);
  plan.moves_target->write_rows(tiles_.offsets[t], tiles_.rows(t), moves.by_row.data()->data(),
                                h5::Transfer::Collective);
}

}  // namespace pointfair::tiles::detail
