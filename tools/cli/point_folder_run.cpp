#include "point_folder_run.hpp"

#include <system_error>
#include <type_traits>

#include "arguments.hpp"
#include "run_support.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/attribute_roles.hpp"
#include "pointfair/io/point_folder.hpp"

namespace pointfair::cli {

namespace fs = std::filesystem;

bool is_folder_input(const fs::path& input) {
  std::error_code ec;
  return fs::is_directory(input, ec);
}

fs::path without_trailing_separator(const fs::path& path) {
  fs::path p = path.lexically_normal();
  if (p.has_filename() || !p.has_parent_path() || p == p.root_path()) return p;
  return p.parent_path();
}

FolderRun plan_folder_run(const fs::path& in_dir, const fs::path& out_dir) {
  FolderRun run;
  run.inputs = io::point_files_in(in_dir);
  std::error_code ec;
  const auto status = fs::status(out_dir, ec);
  if (fs::exists(status) && !fs::is_directory(status))
    throw io::IoError(out_dir.string() + ": exists and is not a folder (a folder input " + in_dir.string() +
                      " writes one file per input file into an output folder)");
  const bool same = fs::exists(status) ? fs::equivalent(in_dir, out_dir, ec)
                                       : fs::weakly_canonical(in_dir, ec) == fs::weakly_canonical(out_dir, ec);
  if (same) throw io::IoError(out_dir.string() + ": the output folder is the input folder: give another one");
  fs::create_directories(out_dir, ec);
  if (ec) throw io::IoError(out_dir.string() + ": cannot create the output folder: " + ec.message());
  for (const fs::path& input : run.inputs) {
    run.outputs.push_back(out_dir / input.filename());
    io::require_output_path(run.outputs.back());
  }
  return run;
}

void require_folder_options(const SelectionOptions& select, const OutputOptions& output, bool reference) {
  const auto refuse = [](const std::string& what) {
    throw UsageError(what + " is not available for a folder of point files yet: run it on a single file");
  };
  if (!select.selection.all()) refuse(select.classes.empty() ? "--returns" : "--classes");
  if (reference) refuse("--neighbors-from");
  if (output.attributes) refuse("--attributes");
  if (output.colour_by != ColourBy::None) refuse("--colour-by");
}

bool check_smooth_paths(std::string& input, std::string& output, const SelectionOptions& select,
                        const OutputOptions& options, bool reference) {
  if (!is_folder_input(input)) {
    // A named pipe or a device at OUT is refused before any work, not after it.
    io::require_output_path(output);
    return false;
  }
  require_folder_options(select, options, reference);
  input = without_trailing_separator(input).string();
  output = without_trailing_separator(output).string();
  return true;
}

io::PointTable read_folder(const FolderRun& run, bool quiet, std::vector<io::PointTable>& parts) {
  parts.clear();
  io::PointTable cloud;
  for (const fs::path& input : run.inputs) {
    parts.push_back(read_input(input, quiet));
    const std::vector<Vec3>& p = parts.back().positions;
    cloud.positions.insert(cloud.positions.end(), p.begin(), p.end());
  }
  return cloud;
}

bool any_normals(const std::vector<io::PointTable>& parts) {
  for (const io::PointTable& part : parts)
    if (!io::normal_columns(part).empty()) return true;
  return false;
}

PointAttributes slice_attributes(const PointAttributes& a, std::size_t first, std::size_t count) {
  const auto slice = [first, count](const auto& column) {
    using Column = std::decay_t<decltype(column)>;
    if (column.empty()) return Column{};
    return Column(column.begin() + static_cast<std::ptrdiff_t>(first),
                  column.begin() + static_cast<std::ptrdiff_t>(first + count));
  };
  PointAttributes s;
  s.normal = slice(a.normal);
  s.d1 = slice(a.d1);
  s.d2 = slice(a.d2);
  s.k1 = slice(a.k1);
  s.k2 = slice(a.k2);
  s.mean_curvature = slice(a.mean_curvature);
  s.laplacian_norm = slice(a.laplacian_norm);
  s.feature = slice(a.feature);
  return s;
}

void write_folder(const FolderRun& run, std::vector<io::PointTable>& parts, std::span<const Vec3> positions,
                  const PointAttributes& attributes, const OutputOptions& output) {
  std::size_t first = 0;
  for (std::size_t f = 0; f < parts.size(); ++f) {
    io::PointTable& part = parts[f];
    const std::size_t n = part.size();
    const auto mine = positions.subspan(first, n);
    part.positions.assign(mine.begin(), mine.end());
    if (!attributes.normal.empty()) add_result_columns(part, slice_attributes(attributes, first, n), output, false);
    write_output(run.outputs[f], part, output, run.inputs[f]);
    first += n;
  }
}

}  // namespace pointfair::cli
