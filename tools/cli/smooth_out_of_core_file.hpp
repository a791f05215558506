#pragma once
// The out-of-core run of `pointfair smooth IN OUT --memory-budget B` without its argument
// handling and printing: a point file imported into tiles in the run's folder (run_folder.hpp)
// or an HDF5 container, smoothed tile by tile within the budget (tiles::smooth_out_of_core),
// exported back to a point file or kept as a container, and the run's summary (the --json
// object). Shared by the command and the Python module's smooth_file, so that both decide,
// run and report the same.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "json_writer.hpp"
#include "method_options.hpp"
#include "selection_options.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"

namespace pointfair::cli {

/// One progress call of the out-of-core run.
struct OutOfCoreProgress {
  /// The import of the input into the run's folder (true), or the run.
  bool importing = false;
  /// The import's pass ("count", "histogram", "scatter") or the run's phase
  /// (tiles::OutOfCoreOptions::progress: "k", "eps", "neighbors", "step", "finish",
  /// "attributes").
  std::string_view phase;
  std::uint64_t done = 0, total = 0;
  /// What keeps the run so far if it stops now (the run's folder or "<OUT>.partial", by file
  /// name), for a resume; empty while nothing would be kept (the import, or
  /// OutOfCoreFileSmooth::keep_interrupted off).
  std::string_view kept_in;
};

struct OutOfCoreFileSmooth {
  /// A point file or a container (.h5); the output is either too (a container output takes a
  /// container's run).
  std::string input;
  std::string output;
  SmoothParams params;
  /// The run's options: memory_budget, resume, temporal_block, halo_scratch, step_blocks,
  /// neighbor_reference (--neighbors-from). `attributes` and `progress` are set by the run.
  tiles::OutOfCoreOptions options;
  /// --classes and --returns (point files in and out only): only the selected points are
  /// imported and smoothed; the export puts them back among the others.
  SelectionOptions select;
  /// The output's options (colours, attributes, encoding, LAS); `quiet` silences the
  /// reader's warnings.
  OutputOptions output_options;
  /// An interrupted or failed run keeps what it committed (the run's folder, or the
  /// container output's partial file) for a resume, and its messages say so. Off: nothing of
  /// a run that fails is left behind (the files it made are removed; an interrupted run found
  /// by a resume still stays).
  bool keep_interrupted = true;
  /// Called through the import and the run; may throw to stop the run (what is kept then is
  /// OutOfCoreProgress::kept_in).
  std::function<void(const OutOfCoreProgress&)> progress;
  /// One-line notes ("smooth: no point of IN selected: ...").
  std::function<void(std::string_view)> note;
  /// When the command started, for the summary's total time (which then counts the checks
  /// before the run); empty: when the run starts.
  std::optional<std::chrono::steady_clock::time_point> started;
};

struct OutOfCoreFileSmoothResult {
  /// The --json object of `pointfair smooth` out of core.
  JsonObject json;
  tiles::OutOfCoreReport report;
  /// --classes or --returns selected no point: nothing was smoothed, the file was written back.
  bool nothing_selected = false;
  double seconds_total = 0.0;
  /// Point-steps per second of this call's steps.
  double rate = 0.0;
};

/// Runs `run` out of core. Call run.params.validate(), io::require_output_path(run.output)
/// and refuse a selection with a container first (the command's argument checks). Throws
/// ParamError (parameters; a budget too small for the run's tiles, with the budget that
/// would do), IoError (files, naming them; an interrupted run in the way), or whatever
/// `progress` throws.
OutOfCoreFileSmoothResult smooth_out_of_core_file(const OutOfCoreFileSmooth& run);

}  // namespace pointfair::cli
