#pragma once
// The in-core run of `pointfair smooth IN OUT` without its printing: read, smooth, add the
// result's columns, write, and the run's summary (the --json object). Shared by the command
// and the Python module's smooth_file, so that both run and report the same.
#include <cstddef>
#include <functional>
#include <string>
#include <string_view>

#include "json_writer.hpp"
#include "method_options.hpp"
#include "run_support.hpp"
#include "selection_options.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair::cli {

struct PointFileSmooth {
  std::string input;
  std::string output;
  /// --neighbors-from: a point file with the input's points in the same order; empty: none.
  std::string reference;
  SmoothParams params;
  /// --classes and --returns: only the selected points are smoothed (and are neighbours); the
  /// others are written back as they were read.
  SelectionOptions select;
  /// The output's options; attribute_prefix is set from `output` by the run.
  OutputOptions output_options;
  /// SmoothOptions::progress of the run (may throw to stop it).
  std::function<void(SmoothStage, std::size_t, std::size_t)> progress;
  /// Called between the phases (after reading, before the attributes, before writing): may
  /// throw to stop the run before anything is written.
  std::function<void()> check;
  /// One-line notes of the run's phases ("smooth: 100 points read; neighbourhoods...").
  std::function<void(std::string_view)> note;
};

struct PointFileSmoothResult {
  /// The --json object of `pointfair smooth`.
  JsonObject json;
  /// Points of the file, and of them the selected ones (all without a selection).
  std::size_t points = 0;
  std::size_t selected = 0;
  /// Whether anything was smoothed (not with a selection of no point).
  bool smoothed = false;
  /// smooth()'s report (its neighbourhoods released).
  SmoothReport report;
  DisplacementStats moved;
  /// Degenerate points of the written result (of the final attributes when they were computed).
  std::size_t degenerate = 0;
  double seconds_total = 0.0;
  /// Point-steps per second of the steps.
  double rate = 0.0;
};

/// Runs `run` in core. Throws as read_points, smooth() and write_points do, or whatever
/// `progress` and `check` throw (nothing is written then). Call run.params.validate() and
/// io::require_output_path(run.output) first to refuse bad arguments before reading.
PointFileSmoothResult smooth_point_file(const PointFileSmooth& run);

}  // namespace pointfair::cli
