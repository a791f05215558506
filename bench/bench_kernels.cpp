// Micro-benchmarks of the method's kernels over cloud sizes (items = points processed).
// Run: build/bench/pointfair_bench_kernels --benchmark_filter=... (Release build).
#include <benchmark/benchmark.h>

#include <limits>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/finish/quadric_projection.hpp"
#include "pointfair/flow/coarse_moves.hpp"
#include "pointfair/frames/robust_frame.hpp"
#include "pointfair/flow/euler_step.hpp"
#include "pointfair/neighbors/kd_tree.hpp"
#include "pointfair/neighbors/knn_grid.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "pointfair/smooth.hpp"

namespace {

using namespace pointfair;

// A noisy closed surface with sharp edges: area samples of the cube, 0.5% noise.
std::vector<Vec3> noisy_cube(std::size_t n) {
  std::vector<Vec3> points = sample_mesh(cube_mesh(), n, 7).points;
  add_noise(points, 0.005 * bounding_box_diagonal(points), 8);
  return points;
}

void BM_KdTreeBuild(benchmark::State& state) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    KdTree tree(points);
    benchmark::DoNotOptimize(&tree);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// The whole-cloud build as build_neighborhoods runs it (cell grid, automatic eps).
void BM_Neighborhoods(benchmark::State& state) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    Neighborhoods nb = build_neighborhoods(points, {.k = 16});
    benchmark::DoNotOptimize(nb.indices.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// The same lists through one k-d tree query per point (the path before the cell grid):
// tree, automatic eps, queries.
void BM_NeighborhoodsKdTree(benchmark::State& state) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  std::vector<Index> all(points.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<Index>(i);
  for (auto _ : state) {
    const KdTree tree(points);
    Neighborhoods nb = build_neighborhoods_kd_tree(tree, all, 16, resolve_eps(points, tree, {.k = 16}));
    benchmark::DoNotOptimize(nb.indices.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// The grid alone: sorting the points into cells.
void BM_CellGridBuild(benchmark::State& state) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    CellGrid grid = build_cell_grid(points, 16, std::numeric_limits<double>::infinity());
    benchmark::DoNotOptimize(grid.order.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// The search alone on a built grid: every point's 16 nearest, no eps bound (the pass
// build_neighborhoods makes before it measures the automatic eps and cuts the rows).
void BM_KnnGridSearch(benchmark::State& state) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  const CellGrid grid = build_cell_grid(points, 16, std::numeric_limits<double>::infinity());
  for (auto _ : state) {
    Neighborhoods nb = grid_neighborhoods(grid, 16, std::numeric_limits<double>::infinity());
    benchmark::DoNotOptimize(nb.indices.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

void BM_Frames(benchmark::State& state) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  const Neighborhoods nb = build_neighborhoods(points, {.k = 16});
  for (auto _ : state) {
    parallel_for(points.size(), [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) benchmark::DoNotOptimize(compute_frame(points[i], nb.of(i), points));
    });
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

void BM_Weingarten(benchmark::State& state) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  const Neighborhoods nb = build_neighborhoods(points, {.k = 16});
  std::vector<Frame> frames(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) frames[i] = compute_frame(points[i], nb.of(i), points);
  for (auto _ : state) {
    parallel_for(points.size(), [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i)
        benchmark::DoNotOptimize(compute_curvature(points[i], frames[i], nb.of(i), points));
    });
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// The robust plane (RobustFrameParams{}: the flow's gate and the finish's normals and fits) of
// every point over its k nearest: 16 as the finish's normals, 200 as its fits.
void BM_RobustPlane(benchmark::State& state) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  const std::size_t k = static_cast<std::size_t>(state.range(1));
  const Neighborhoods nb = build_neighborhoods(points, {.k = static_cast<int>(k)});
  const RobustFrameParams params;
  for (auto _ : state) {
    parallel_for(points.size(), [&](std::size_t b, std::size_t e) {
      std::vector<Vec3> offsets(k);
      std::vector<double> weights(k + 1), scratch(k + 1);
      for (std::size_t i = b; i < e; ++i) {
        const auto row = nb.of(i);
        offsets.resize(row.size());
        for (std::size_t j = 0; j < row.size(); ++j) offsets[j] = points[row[j]] - points[i];
        weights.resize(row.size() + 1);
        scratch.resize(row.size() + 1);
        benchmark::DoNotOptimize(fit_robust_plane(offsets, params, weights, scratch));
      }
    });
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// The whole quadric finish at its defaults (both passes, fit sharing, no anchors) on the
// noisy cube.
void BM_QuadricFinish(benchmark::State& state) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    std::vector<Vec3> finished = points;
    finish_with_quadrics(finished, QuadricProjectionParams{});
    benchmark::DoNotOptimize(finished.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// The coarse level's moves carried to every point (add_coarse_moves, 8 nearest): every second
// point of the noisy cube an anchor, moved halfway to the cube's surface.
void BM_CoarseMoves(benchmark::State& state) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  std::vector<Vec3> anchors, moved;
  for (std::size_t i = 0; i < points.size(); i += 2) {
    anchors.push_back(points[i]);
    moved.push_back(0.5 * points[i]);
  }
  const MortonGrid grid = morton_grid(points);
  for (auto _ : state) {
    std::vector<Vec3> positions = points;
    benchmark::DoNotOptimize(add_coarse_moves(positions, anchors, moved, 8, grid));
    benchmark::DoNotOptimize(positions.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// One step of `params` at k over the noisy cube.
void step_benchmark(benchmark::State& state, const FlowParams& params, int k) {
  const auto points = noisy_cube(static_cast<std::size_t>(state.range(0)));
  const Neighborhoods nb = build_neighborhoods(points, {.k = k});
  const double lambda = resolve_lambda(points, nb, params);
  std::vector<Vec3> next(points.size());
  for (auto _ : state) {
    euler_step(points, nb, {}, params, lambda, next);
    benchmark::DoNotOptimize(next.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// The paper's step at k 16.
void paper_step_benchmark(benchmark::State& state, Flow flow) {
  FlowParams params;
  params.flow = flow;
  step_benchmark(state, params, 16);
}
void BM_IsotropicStep(benchmark::State& state) { paper_step_benchmark(state, Flow::Isotropic); }
void BM_AnisotropicStep(benchmark::State& state) { paper_step_benchmark(state, Flow::Anisotropic); }

// The defaults' step (SmoothParams{}.flow: the plane cut-off origin, the robust plane behind
// its gate) at k 48, the automatic k under noise of a spacing or more, with the robust plane
// gated (the defaults) or fitted at every point (gate 0): the ratio of the two is what the
// gate saves per step.
void default_step_benchmark(benchmark::State& state, double gate, int k = 48) {
  FlowParams params = SmoothParams{}.flow;
  params.robust.gate = gate;
  step_benchmark(state, params, k);
}
void BM_DefaultStepGated(benchmark::State& state) { default_step_benchmark(state, SmoothParams{}.flow.robust.gate); }
void BM_DefaultStepRobustEverywhere(benchmark::State& state) { default_step_benchmark(state, 0.0); }
// A chosen k of 96: twice the automatic k's work a point, within the fast kernel's bound.
void BM_DefaultStepGatedK96(benchmark::State& state) {
  default_step_benchmark(state, SmoothParams{}.flow.robust.gate, 96);
}

}  // namespace

BENCHMARK(BM_KdTreeBuild)->RangeMultiplier(4)->Range(10'000, 4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Neighborhoods)->RangeMultiplier(4)->Range(10'000, 4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_NeighborhoodsKdTree)->RangeMultiplier(4)->Range(10'000, 4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CellGridBuild)->RangeMultiplier(4)->Range(10'000, 4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_KnnGridSearch)->RangeMultiplier(4)->Range(10'000, 4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Frames)->RangeMultiplier(4)->Range(10'000, 4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Weingarten)->RangeMultiplier(4)->Range(10'000, 4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_IsotropicStep)->RangeMultiplier(4)->Range(10'000, 4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_AnisotropicStep)->RangeMultiplier(4)->Range(10'000, 4'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DefaultStepGated)->RangeMultiplier(4)->Range(10'000, 1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DefaultStepRobustEverywhere)->RangeMultiplier(4)->Range(10'000, 1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK(BM_DefaultStepGatedK96)->RangeMultiplier(4)->Range(10'000, 1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RobustPlane)->ArgsProduct({{100'000}, {16, 200}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_QuadricFinish)->RangeMultiplier(10)->Range(10'000, 1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CoarseMoves)->RangeMultiplier(10)->Range(100'000, 1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
