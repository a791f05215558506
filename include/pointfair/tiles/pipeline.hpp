#pragma once
// A bounded three-stage pipeline over the tiles of a pass: item i+1 is read while item i is
// computed and item i-1 is written. Reading and writing run on the calling thread only (so
// every HDF5 call stays on one thread: Debian's libhdf5 is not thread-safe); computing runs
// on one worker thread, which may itself use parallel_for (any back end) for the item.
//
// Items go through the stages in order, one at a time per stage, and item i always uses slot
// i % slots: at most `slots` items are in flight, so the caller can allocate (and count
// within its memory budget) exactly `slots` working buffers. With slots == 1 the stages run
// one after the other on the calling thread (no overlap, no worker).
#include <cstddef>
#include <functional>

namespace pointfair::tiles {

struct PipelineStages {
  /// Loads item `item` into slot `slot`. Calling thread.
  std::function<void(std::size_t item, std::size_t slot)> read;
  /// Computes the item held by slot `slot`. Worker thread (calling thread when slots == 1).
  std::function<void(std::size_t slot)> compute;
  /// Stores the result of item `item`, held by slot `slot`; the slot is free afterwards.
  /// Calling thread.
  std::function<void(std::size_t item, std::size_t slot)> write;
};

/// Runs items 0..count-1 through read, compute and write with at most `slots` (>= 1) items in
/// flight. The first exception of any stage stops the pipeline (the worker finishes its
/// current item and ends) and is rethrown here; items after it are not written.
void run_pipeline(std::size_t count, std::size_t slots, const PipelineStages& stages);

}  // namespace pointfair::tiles
