#pragma once
// How an out-of-core run shares its memory budget: the budget when none is given, the room
// kept for the automatic lambda's sample and the run's tables, and the tile size that fits in
// the rest.
#include <cstdint>

namespace pointfair {
struct SmoothParams;
}

namespace pointfair::tiles {

/// The memory budget of an out-of-core run, an import and an export when none is given
/// (OutOfCoreOptions, StreamImportOptions, the command line's --memory-budget): 256 MiB.
inline constexpr std::uint64_t kDefaultMemoryBudget = std::uint64_t{256} << 20;

/// The least memory budget the streaming import accepts (import_points): 16 MiB.
inline constexpr std::uint64_t kMinImportBudget = std::uint64_t{16} << 20;

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

/// The largest k the flow of `params` may use: its k, or kAutoKMax for the automatic k (which
/// is not known before the cloud is read).
int flow_k_bound(const SmoothParams& params);

/// Most points per tile of a run of `params` under `budget`: tile_points_for_budget with the
/// largest of flow_k_bound and the finish's k.
std::uint64_t run_tile_points(std::uint64_t budget, const SmoothParams& params);

/// Most points per tile of an import under `budget`: as a run under the same budget sizes its
/// tiles for the largest automatic k and the default finish's k, so that such a run takes the
/// container as it is.
std::uint64_t import_tile_points(std::uint64_t budget);

/// The budget to name when a run whose tiles follow its budget (tile_points_for_budget) is
/// refused, having needed `needed` bytes (BudgetError::needed): twice that, in whole MiB.
/// What exceeds the rule's share a tile point is the halo of small tiles (few points, but a
/// perimeter as wide as their neighbourhoods): with tiles twice as large or more, a halo
/// grows by at most the square root of that.
std::uint64_t budget_to_name(std::uint64_t needed);

}  // namespace pointfair::tiles
