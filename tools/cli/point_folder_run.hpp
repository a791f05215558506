#pragma once
// `pointfair smooth IN_DIR OUT_DIR`: a folder of point files (tiles of one scan) smoothed as one
// cloud, each file's points written back to a file of the same name and format in OUT_DIR, with
// that file's own header, records and attributes. The cloud is the files' points concatenated in
// file-name order (io::point_files_in), so the result is the one of smoothing that
// concatenation. The pieces the in-core and out-of-core runs share: the plan of the run's
// files, the checks before any work, and the in-core read and write.
#include <cstddef>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "method_options.hpp"
#include "selection_options.hpp"
#include "pointfair/io/point_table.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair::cli {

/// The files of a folder run: inputs[i] is written to outputs[i].
struct FolderRun {
  std::vector<std::filesystem::path> inputs;
  std::vector<std::filesystem::path> outputs;
};

/// True when `input` names a folder: the run takes every point file in it.
bool is_folder_input(const std::filesystem::path& input);

/// `path` without trailing separators ("tiles/" is "tiles"), so that its file name is the
/// folder's name (the run's folder beside it is named after it).
std::filesystem::path without_trailing_separator(const std::filesystem::path& path);

/// Checks the folder run `in_dir` -> `out_dir` before any work and makes `out_dir` when it is
/// missing. Throws IoError naming the folder when `in_dir` holds no point file, `out_dir` is
/// `in_dir` (or is a file), or an output's name is taken by something other than a regular
/// file (io::require_output_path); an existing regular output is replaced when the run
/// completes, as a single file's output is.
FolderRun plan_folder_run(const std::filesystem::path& in_dir, const std::filesystem::path& out_dir);

/// Throws UsageError for what a folder run does not take (yet): --classes and --returns,
/// --neighbors-from, --attributes and --colour-by (whose colour range would span every file).
void require_folder_options(const SelectionOptions& select, const OutputOptions& output, bool reference);

/// The path checks of `smooth IN OUT` before any work: for a folder IN its options
/// (require_folder_options; `reference`: --neighbors-from was given) and both paths without
/// trailing separators; for a file IN, OUT checked by io::require_output_path. Returns whether
/// IN is a folder.
bool check_smooth_paths(std::string& input, std::string& output, const SelectionOptions& select,
                        const OutputOptions& options, bool reference);

/// Reads every input of `run` into `parts` (each file's table whole, as read_input reads it)
/// and returns their positions concatenated in order (a table with no attributes).
io::PointTable read_folder(const FolderRun& run, bool quiet, std::vector<io::PointTable>& parts);

/// Whether any of `parts` has normal columns, which the smoothed cloud's normals replace.
bool any_normals(const std::vector<io::PointTable>& parts);

/// Points [first, first + count) of every non-empty column of `attributes`.
PointAttributes slice_attributes(const PointAttributes& attributes, std::size_t first, std::size_t count);

/// Writes parts[i] to run.outputs[i] (write_output, refusing to overwrite run.inputs[i]) with
/// its slice of `positions` and, when attributes.normal is not empty, its slice of the normals
/// in place of its own (add_result_columns): the concatenation's points go back to their files.
void write_folder(const FolderRun& run, std::vector<io::PointTable>& parts, std::span<const Vec3> positions,
                  const PointAttributes& attributes, const OutputOptions& output);

}  // namespace pointfair::cli
