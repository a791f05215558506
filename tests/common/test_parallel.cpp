// The parallel facade, and MATH.md step 9: results bit-identical for any thread count.
#include "pointfair/common/parallel.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "pointfair/smooth.hpp"
#include "support/checks.hpp"
#include "support/clouds.hpp"

namespace pointfair {
namespace {

// Every test here changes the global thread count; put the default back afterwards.
class Parallel : public ::testing::Test {
 protected:
  void TearDown() override { set_thread_count(0); }
};

TEST_F(Parallel, ThreadCountSetting) {
  set_thread_count(0);
  const int default_threads = thread_count();
  EXPECT_GE(default_threads, 1);
  set_thread_count(1);
  EXPECT_EQ(thread_count(), 1);
  set_thread_count(3);
  EXPECT_EQ(thread_count(), 3);
  set_thread_count(0);
  EXPECT_EQ(thread_count(), default_threads);
  EXPECT_THROW(set_thread_count(-1), std::invalid_argument);
  EXPECT_EQ(thread_count(), default_threads) << "a rejected value changes nothing";
}

TEST_F(Parallel, CoversEveryIndexExactlyOnce) {
  for (const int threads : {1, 2, 0}) {
    set_thread_count(threads);
    for (const std::size_t n : {0u, 1u, 7u, 1024u, 1025u, 10000u}) {
      for (const std::size_t grain : {0u, 1u, 100u, 4096u}) {
        std::vector<std::atomic<int>> hits(n);
        std::atomic<int> calls{0};
        parallel_for(n, [&](std::size_t begin, std::size_t end) {
          ASSERT_LT(begin, end);
          ASSERT_LE(end, n);
          for (std::size_t i = begin; i < end; ++i) hits[i].fetch_add(1);
          calls.fetch_add(1);
        }, grain);
        int wrong = 0;
        for (const auto& h : hits) wrong += h.load() != 1;
        EXPECT_EQ(wrong, 0) << "n=" << n << " grain=" << grain << " threads=" << threads;
        if (n == 0) {
          EXPECT_EQ(calls.load(), 0);
        }
        if (threads == 1 && n > 0) {
          EXPECT_EQ(calls.load(), 1) << "one thread: one call";
        }
        // Two threads and many grains: the range is really split (the determinism tests
        // below would otherwise compare two serial runs).
        if (threads == 2 && grain > 0 && n >= 8 * grain) {
          EXPECT_GT(calls.load(), 1) << "n=" << n << " grain=" << grain;
        }
      }
    }
  }
}

TEST_F(Parallel, ExceptionsPropagate) {
  for (const int threads : {1, 2}) {
    set_thread_count(threads);
    EXPECT_THROW(parallel_for(10000, [](std::size_t begin, std::size_t end) {
      if (begin <= 5000 && 5000 < end) throw std::runtime_error("boom");
    }, 100), std::runtime_error);
  }
}

// ---- Determinism: 1 thread vs 2 threads, memcmp-equal results. ----

// More points than two grains of every kernel (2048 for the step), so two threads really
// split the work.
std::vector<Vec3> cloud() { return test::noisy_cube(12000, 0.01, 77); }

template <class F>
auto with_threads(int threads, F f) {
  set_thread_count(threads);
  auto result = f();
  set_thread_count(0);
  return result;
}

TEST_F(Parallel, NeighbourhoodsAndLambdaAreThreadCountIndependent) {
  const std::vector<Vec3> points = cloud();
  const auto build = [&] { return build_neighborhoods(points, NeighborParams{}); };
  const Neighborhoods a = with_threads(1, build);
  const Neighborhoods b = with_threads(2, build);
  EXPECT_EQ(a.stride, b.stride);
  EXPECT_EQ(a.eps, b.eps);
  EXPECT_TRUE(test::bitwise_equal(a.indices, b.indices));
  EXPECT_TRUE(test::bitwise_equal(a.counts, b.counts));
  const double la = with_threads(1, [&] { return auto_lambda(points, a, 2.0); });
  const double lb = with_threads(2, [&] { return auto_lambda(points, a, 2.0); });
  EXPECT_EQ(la, lb);
}

struct Variant {
  const char* name;
  FlowParams flow;
};

std::vector<Variant> variants() {
  std::vector<Variant> v;
  FlowParams p;
  v.push_back({"anisotropic sharp", p});
  p.cutoff = Cutoff::Continuous;
  v.push_back({"anisotropic continuous", p});
  p = FlowParams{};
  p.flow = Flow::Isotropic;
  v.push_back({"isotropic", p});
  p = FlowParams{};
  p.constrain_normal = true;
  v.push_back({"constrain normal", p});
  p = FlowParams{};
  p.feature_gated = true;
  p.features.mode = FeatureMode::EdgeQuotient;
  v.push_back({"feature gated", p});
  p.features.mode = FeatureMode::MaxCurvature;
  v.push_back({"feature gated (max curvature)", p});
  return v;
}

TEST_F(Parallel, EulerStepIsThreadCountIndependent) {
  const std::vector<Vec3> points = cloud();
  const Neighborhoods n = build_neighborhoods(points, NeighborParams{});
  const double lambda = auto_lambda(points, n, 2.0);
  for (const auto& v : variants()) {
    const auto run = [&] {
      std::vector<Vec3> next(points.size());
      const StepStats stats = euler_step(points, n, {}, v.flow, lambda, next);
      return std::make_pair(next, stats.degenerate);
    };
    const auto a = with_threads(1, run);
    const auto b = with_threads(2, run);
    EXPECT_TRUE(test::bitwise_equal(a.first, b.first)) << v.name;
    EXPECT_EQ(a.second, b.second) << v.name;
    EXPECT_GT(test::max_distance(a.first, points), 0.0) << v.name;
  }
}

TEST_F(Parallel, SmoothIsThreadCountIndependent) {
  const std::vector<Vec3> input = cloud();
  for (const auto& v : variants()) {
    // Two steps with a rebuild before the second: fixed and rebuilt neighbourhoods both run.
    SmoothParams params;
    params.finish.reset();  // the flow alone
    params.flow = v.flow;
    params.steps = 2;
    params.rebuild_interval = 1;
    const auto run = [&] {
      std::vector<Vec3> points = input;
      const SmoothReport r = smooth(points, params);
      return std::make_tuple(points, r.lambda, r.rebuilds);
    };
    const auto a = with_threads(1, run);
    const auto b = with_threads(2, run);
    EXPECT_TRUE(test::bitwise_equal(std::get<0>(a), std::get<0>(b))) << v.name;
    EXPECT_EQ(std::get<1>(a), std::get<1>(b)) << v.name;
    EXPECT_EQ(std::get<2>(a), 1) << v.name;
  }
}

TEST_F(Parallel, AttributesAreThreadCountIndependent) {
  const std::vector<Vec3> points = cloud();
  const Neighborhoods n = build_neighborhoods(points, NeighborParams{});
  const double lambda = auto_lambda(points, n, 2.0);
  for (const auto& v : variants()) {
    const auto run = [&] { return compute_attributes(points, n, v.flow, lambda); };
    const PointAttributes a = with_threads(1, run);
    const PointAttributes b = with_threads(2, run);
    EXPECT_TRUE(test::bitwise_equal(a.normal, b.normal)) << v.name;
    EXPECT_TRUE(test::bitwise_equal(a.d1, b.d1));
    EXPECT_TRUE(test::bitwise_equal(a.d2, b.d2));
    EXPECT_TRUE(test::bitwise_equal(a.k1, b.k1));
    EXPECT_TRUE(test::bitwise_equal(a.k2, b.k2));
    EXPECT_TRUE(test::bitwise_equal(a.mean_curvature, b.mean_curvature));
    EXPECT_TRUE(test::bitwise_equal(a.laplacian_norm, b.laplacian_norm));
    EXPECT_TRUE(test::bitwise_equal(a.feature, b.feature));
    EXPECT_EQ(a.degenerate, b.degenerate);
  }
}

// Installs `flag` as the stop flag for its lifetime.
struct StopFlagGuard {
  explicit StopFlagGuard(const std::atomic<int>& flag) { set_stop_flag(&flag); }
  ~StopFlagGuard() { set_stop_flag(nullptr); }
  StopFlagGuard(const StopFlagGuard&) = delete;
  StopFlagGuard& operator=(const StopFlagGuard&) = delete;
};

// The stop flag (set_stop_flag): once set, a loop skips the ranges it has not started and
// throws Stopped; unset, it changes nothing.
TEST_F(Parallel, StopFlagEndsALoopEarly) {
  std::atomic<int> flag{0};
  const StopFlagGuard guard(flag);
  for (const int threads : {1, 2}) {
    set_thread_count(threads);
    const std::size_t n = 40 * kStopCheckRange;
    std::atomic<std::size_t> done{0};
    parallel_for(n, [&](std::size_t b, std::size_t e) { done += e - b; });
    EXPECT_EQ(done.load(), n) << "an unset flag stops nothing";
    done = 0;
    EXPECT_THROW(parallel_for(n, [&](std::size_t b, std::size_t e) {
                   done += e - b;
                   flag.store(1);  // the first range raises the flag: the rest is skipped
                 }),
                 Stopped);
    EXPECT_LT(done.load(), n / 2) << threads << " threads";
    EXPECT_THROW(parallel_for(1, [](std::size_t, std::size_t) {}), Stopped) << "a raised flag stops at once";
    flag.store(0);
  }
}

// smooth() stopped through the flag during a step leaves the last completed step.
TEST_F(Parallel, StopFlagDuringSmoothLeavesTheLastCompletedStep) {
  const std::vector<Vec3> input = cloud();
  SmoothParams params;
  params.finish.reset();  // the flow alone
  params.steps = 6;
  std::atomic<int> flag{0};
  const StopFlagGuard guard(flag);
  SmoothOptions options;
  options.progress = [&](SmoothStage, std::size_t done, std::size_t) {
    if (done == 2) flag.store(1);  // the third step's first loop stops
  };
  std::vector<Vec3> stopped = input;
  EXPECT_THROW(smooth(stopped, params, options), Stopped);
  set_stop_flag(nullptr);
  std::vector<Vec3> two = input;
  params.steps = 2;
  smooth(two, params);
  EXPECT_TRUE(test::bitwise_equal(stopped, two));
}

// ... and during the finish, the flow's result (no finish pass completed).
TEST_F(Parallel, StopFlagDuringTheFinishLeavesTheFlowsResult) {
  const std::vector<Vec3> input = cloud();
  SmoothParams params;
  params.steps = 2;
  params.finish->k = 30;
  std::atomic<int> flag{0};
  const StopFlagGuard guard(flag);
  SmoothOptions options;
  std::size_t finish_calls = 0;
  options.progress = [&](SmoothStage stage, std::size_t, std::size_t) {
    if (stage == SmoothStage::Finish && finish_calls++ == 0) flag.store(1);
  };
  std::vector<Vec3> stopped = input;
  EXPECT_THROW(smooth(stopped, params, options), Stopped);
  EXPECT_EQ(finish_calls, 1u) << "the finish went on after the flag";
  set_stop_flag(nullptr);
  std::vector<Vec3> flowed = input;
  params.finish.reset();
  smooth(flowed, params);
  EXPECT_TRUE(test::bitwise_equal(stopped, flowed));
}

}  // namespace
}  // namespace pointfair
