#pragma once
// The quadric finish's parameter table (QuadricProjectionParams): one entry per parameter
// with its names in the resume key, the --json summary and the run file's attributes. The
// table is in the resume key's order; the --json block has an order of its own
// (kQuadricJsonOrder), which covers the same entries.
#include <array>
#include <string_view>

#include "pointfair/common/parameter.hpp"
#include "pointfair/finish/quadric_projection.hpp"

namespace pointfair {

using QuadricParameter = Parameter<QuadricProjectionParams>;

/// Whether the passes before the last fit otherwise than the last
/// (QuadricProjectionParams::early_degree, early_iterations).
constexpr bool early_passes_differ(const QuadricProjectionParams& q) {
  return q.passes > 1 && (q.early_degree != q.degree || q.early_iterations != q.iterations);
}

inline constexpr std::array<QuadricParameter, 17> kQuadricParameters{{
    {"quadric_k", "k", "quadric_k", [](const QuadricProjectionParams& q) { return integer_value(q.k); }},
    {"quadric_normal_neighbors", "", "",
     [](const QuadricProjectionParams& q) { return integer_value(q.normal_neighbors); }},
    {"quadric_angle", "angle_degrees", "quadric_angle",
     [](const QuadricProjectionParams& q) { return real_value(q.normal_angle); }},
    {"quadric_iterations", "iterations", "", [](const QuadricProjectionParams& q) { return integer_value(q.iterations); }},
    {"quadric_bound", "", "", [](const QuadricProjectionParams& q) { return real_value(q.inlier_bound); }},
    {"quadric_degree", "degree", "quadric_degree",
     [](const QuadricProjectionParams& q) { return integer_value(q.degree); }},
    {"quadric_passes", "passes", "quadric_passes",
     [](const QuadricProjectionParams& q) { return integer_value(q.passes); }},
    {"quadric_curvature_reach", "curvature_reach", "",
     [](const QuadricProjectionParams& q) { return real_value(q.curvature_reach); }},
    {"quadric_min_k", "min_k", "", [](const QuadricProjectionParams& q) { return integer_value(q.min_k); }},
    {"quadric_frame_seed", "", "", [](const QuadricProjectionParams& q) { return integer_value(q.frame.seed_neighbors); }},
    {"quadric_frame_iterations", "", "",
     [](const QuadricProjectionParams& q) { return integer_value(q.frame.iterations); }},
    {"quadric_frame_bound", "", "", [](const QuadricProjectionParams& q) { return real_value(q.frame.inlier_bound); }},
    {"quadric_placement_turn", "", "", [](const QuadricProjectionParams& q) { return real_value(q.placement_turn); }},
    // Named in the key only when on: runs started before fit sharing still resume.
    {"quadric_share", "share", "quadric_share", [](const QuadricProjectionParams& q) { return integer_value(q.share_stride); },
     [](const QuadricProjectionParams& q) { return q.share_stride != 1; }},
    {"quadric_share_turn", "share_turn", "", [](const QuadricProjectionParams& q) { return real_value(q.share_turn); },
     [](const QuadricProjectionParams& q) { return q.share_stride != 1; }},
    // Named in the key only where the early passes differ from the last: runs started
    // before them (every pass as the last) still resume with those values.
    {"quadric_early_degree", "early_degree", "",
     [](const QuadricProjectionParams& q) { return integer_value(q.early_degree); }, early_passes_differ},
    {"quadric_early_iterations", "early_iterations", "",
     [](const QuadricProjectionParams& q) { return integer_value(q.early_iterations); }, early_passes_differ},
}};

/// The --json block's order of the table's entries (by their --json names), after "enabled".
inline constexpr std::array<std::string_view, 11> kQuadricJsonOrder{
    "k", "angle_degrees", "degree", "passes", "iterations", "early_degree", "early_iterations",
    "curvature_reach", "min_k", "share", "share_turn"};
static_assert(covers<QuadricProjectionParams>(kQuadricParameters, &QuadricParameter::json, kQuadricJsonOrder));
static_assert(names_only_entries<QuadricProjectionParams>(kQuadricParameters, &QuadricParameter::json,
                                                          kQuadricJsonOrder));

}  // namespace pointfair
