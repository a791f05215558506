// The tile pipeline keeps its stages in item order, reads and writes on the calling thread,
// never holds more than `slots` items, overlaps reading with computing, and stops on errors.
#include "pointfair/tiles/pipeline.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

struct Trace {
  std::mutex mutex;
  std::vector<std::size_t> reads, writes;
  std::vector<long long> slot_item;  // the item each slot holds, -1 when free
  std::size_t in_flight = 0, most_in_flight = 0;
  bool io_off_caller = false, wrong_slot = false, overlapped = false;
};

PipelineStages traced(Trace& t, std::size_t slots, std::vector<long long>& results,
                      std::thread::id caller, int throw_at = -1) {
  t.slot_item.assign(slots, -1);
  PipelineStages s;
  s.read = [&t, slots, caller](std::size_t item, std::size_t slot) {
    const std::lock_guard lock(t.mutex);
    t.io_off_caller |= std::this_thread::get_id() != caller;
    t.wrong_slot |= slot != item % slots || t.slot_item[slot] != -1;
    t.slot_item[slot] = static_cast<long long>(item);
    t.reads.push_back(item);
    t.most_in_flight = std::max(t.most_in_flight, ++t.in_flight);
  };
  s.compute = [&t, &results, throw_at](std::size_t slot) {
    long long item = 0;
    {
      const std::lock_guard lock(t.mutex);
      item = t.slot_item[slot];
    }
    if (item == throw_at) throw std::runtime_error("compute failed");
    // Work that a parallel_for splits, as the out-of-core step does.
    std::vector<long long> part(64, 0);
    parallel_for(part.size(), [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) part[i] = item * static_cast<long long>(i);
    }, 8);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    long long sum = 0;
    for (const long long v : part) sum += v;
    const std::lock_guard lock(t.mutex);
    // Another item was read while this one was being computed.
    t.overlapped |= t.reads.size() > static_cast<std::size_t>(item) + 1;
    results[static_cast<std::size_t>(item)] = sum;
  };
  s.write = [&t, slots, caller](std::size_t item, std::size_t slot) {
    const std::lock_guard lock(t.mutex);
    t.io_off_caller |= std::this_thread::get_id() != caller;
    t.wrong_slot |= slot != item % slots || t.slot_item[slot] != static_cast<long long>(item);
    t.slot_item[slot] = -1;
    t.writes.push_back(item);
    --t.in_flight;
  };
  return s;
}

TEST(Pipeline, StagesInOrderWithinTheSlotsOnTheCallingThread) {
  set_thread_count(2);
  for (const std::size_t slots : {1u, 2u, 3u, 5u}) {
    for (const std::size_t count : {0u, 1u, 2u, 17u}) {
      SCOPED_TRACE(testing::Message() << slots << " slots, " << count << " items");
      Trace t;
      std::vector<long long> results(count, -1);
      run_pipeline(count, slots, traced(t, slots, results, std::this_thread::get_id()));
      std::vector<std::size_t> expected(count);
      for (std::size_t i = 0; i < count; ++i) expected[i] = i;
      EXPECT_EQ(t.reads, expected);
      EXPECT_EQ(t.writes, expected);
      EXPECT_LE(t.most_in_flight, slots);
      EXPECT_FALSE(t.io_off_caller);
      EXPECT_FALSE(t.wrong_slot);
      for (std::size_t i = 0; i < count; ++i) EXPECT_EQ(results[i], static_cast<long long>(i) * 2016);
      if (slots > 1 && count > 2) {
        EXPECT_TRUE(t.overlapped) << "no read while computing";
      }
      if (slots == 1) {
        EXPECT_FALSE(t.overlapped);
      }
    }
  }
  set_thread_count(0);
}

TEST(Pipeline, AComputeErrorStopsItAndReachesTheCaller) {
  Trace t;
  std::vector<long long> results(20, -1);
  EXPECT_THROW(run_pipeline(20, 3, traced(t, 3, results, std::this_thread::get_id(), 6)), std::runtime_error);
  EXPECT_LT(t.writes.size(), 7u);  // nothing from item 6 on
  EXPECT_LE(t.reads.size(), 9u);
}

TEST(Pipeline, AReadOrWriteErrorStopsTheWorker) {
  for (const bool in_write : {false, true}) {
    Trace t;
    std::vector<long long> results(30, -1);
    PipelineStages s = traced(t, 3, results, std::this_thread::get_id());
    auto& stage = in_write ? s.write : s.read;
    stage = [inner = stage](std::size_t item, std::size_t slot) {
      if (item == 4) throw std::runtime_error("I/O failed");
      inner(item, slot);
    };
    EXPECT_THROW(run_pipeline(30, 3, s), std::runtime_error);
    if (in_write) {
      EXPECT_EQ(t.writes.size(), 4u);
    } else {
      EXPECT_LE(t.writes.size(), 4u);
    }
  }
  EXPECT_THROW(run_pipeline(3, 0, {}), ParamError);
}

}  // namespace
