// Micro-benchmarks of the method's kernels over cloud sizes (items = points processed).
// Run: build/bench/pointfair_bench_kernels --benchmark_filter=... (Release build).
#include <benchmark/benchmark.h>

#include <limits>
#include <vector>

#include "pointfair/common/parallel.hpp"
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
void default_step_benchmark(benchmark::State& state, double gate) {
  FlowParams params = SmoothParams{}.flow;
  params.robust.gate = gate;
  step_benchmark(state, params, 48);
}
void BM_DefaultStepGated(benchmark::State& state) { default_step_benchmark(state, SmoothParams{}.flow.robust.gate); }
void BM_DefaultStepRobustEverywhere(benchmark::State& state) { default_step_benchmark(state, 0.0); }

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

BENCHMARK_MAIN();
