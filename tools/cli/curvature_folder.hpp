#pragma once
// `pointfair curvature IN_DIR OUT_DIR`: the curvatures of a folder of point files taken as one
// cloud (point_folder_run.hpp), each file written back with its points' columns; and the
// summary every curvature run prints.
#include <cstddef>
#include <filesystem>
#include <string>

#include "method_options.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair::cli {

/// What a curvature run prints (stderr) and reports (--json).
struct CurvatureSummary {
  std::string input, output;
  /// Files of a folder run; 0 for a single file.
  std::size_t files = 0;
  std::size_t points = 0;
  int k = 0;
  double eps = 0.0, lambda = 0.0, seconds = 0.0;
};

/// The run's line on stderr (unless output.quiet) and its --json object on stdout (with output.json).
void print_curvature_summary(const CurvatureSummary& summary, const PointAttributes& attributes,
                             const SmoothParams& params, const OutputOptions& output);

/// Runs curvature on the folder `in_dir` into `out_dir` and prints its summary as the command
/// does; returns the exit code. Colours (--colour-by, or kmax for a file without colours of its
/// own) take one range over the whole cloud.
int run_curvature_folder(const std::filesystem::path& in_dir, const std::filesystem::path& out_dir,
                         const SmoothParams& params, const OutputOptions& output);

}  // namespace pointfair::cli
