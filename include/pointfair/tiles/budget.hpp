#pragma once
// How an out-of-core run shares its memory budget: the room kept for the automatic lambda's
// sample and the run's tables, and the tile size that fits in the rest.
#include <cstdint>

namespace pointfair::tiles {

/// The room a run keeps of its budget for its lambda sample and its tables: a sixteenth of
/// the budget, at least 2 MiB (the whole sample of a small cloud) or half of a smaller budget.
/// The sample is gathered (its lists and positions held, brought up to date by the steps'
/// writes) only where it takes at most that; else each lambda reads it from the run file in
/// pieces (the same bits, a little more I/O), so that a small budget keeps its room for the
/// tiles.
std::uint64_t lambda_sample_room(std::uint64_t budget);

/// Most points per tile for which a run with k neighbours (the largest of the flow's and the
/// quadric finish's) stays within `budget` bytes: the budget less the room for the sample
/// (lambda_sample_room), over the largest working set a tile point takes with its halo. The
/// tile size grows with the budget, so a larger budget never needs more than it gives. At
/// least 64.
std::uint64_t tile_points_for_budget(std::uint64_t budget, int k);

/// The budget to name when a run whose tiles follow its budget (tile_points_for_budget) is
/// refused, having needed `needed` bytes (BudgetError::needed): twice that, in whole MiB.
/// What exceeds the rule's share a tile point is the halo of small tiles (few points, but a
/// perimeter as wide as their neighbourhoods): with tiles twice as large or more, a halo
/// grows by at most the square root of that.
std::uint64_t budget_to_name(std::uint64_t needed);

}  // namespace pointfair::tiles
