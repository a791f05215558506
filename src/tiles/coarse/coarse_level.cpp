// The coarse level out of core (coarse_stages.hpp): smooth()'s run_coarse_level and the fine
// run after it, each stage's result a file in a work folder beside the output's partial file
// ("<output>.partial.coarse"), so that a killed run resumes from the last stage it finished:
//   sample.h5   the coarse sample (a container with the input's tiles)
//   coarse.h5   the flow on it (a run of its own, without the finish; resumable itself)
//   start.h5    every input point moved by the coarse points' moves: the fine run's start
// The fine run is the output's run, started from start.h5 (OutOfCoreOptions::start_positions).
// The stages run on rank 0 (the others wait); the runs on every rank.
#include <chrono>
#include <cmath>
#include <exception>
#include <sstream>

#include "coarse_stages.hpp"
#include "pointfair/io/file_lock.hpp"
#include "pointfair/tiles/ranks.hpp"
#include "../run/run.hpp"

namespace pointfair::tiles {

namespace coarse {

namespace {

constexpr const char* kKey = "coarse_key";

// The files a coarse level's folder may hold (a nested level's folder among them).
constexpr const char* kFolderNames[] = {"sample.h5", "sample.h5.tmp", "coarse.h5", "coarse.h5.partial",
                                        "coarse.h5.partial.coarse", "start.h5", "start.h5.tmp"};

// Everything the folder's files depend on: every parameter and the input's bytes.
std::string stage_key(const fs::path& input, const SmoothParams& params) {
  std::ostringstream s;
  s.precision(17);
  const CoarseLevelParams& c = *params.coarse;
  s << detail::parameters_key(params) << " coarse_ratio=" << c.ratio << " coarse_cell=" << c.cell_spacings
    << " coarse_fine_steps=" << c.fine_steps << " coarse_interpolation_k=" << c.interpolation_k
    << " coarse_levels=" << c.levels << " coarse_min_noise_ratio=" << c.min_noise_ratio
    << " input=" << io::file_digest(input);
  return s.str();
}

// Makes the folder, or with `resume` reopens it (it must hold only the stages' files), and
// locks it.
std::unique_ptr<io::FolderLock> open_folder(const fs::path& folder, bool resume) {
  std::error_code ec;
  const bool made = fs::create_directory(folder, ec);
  if (ec) throw io::IoError(folder.string() + ": cannot create the coarse level's folder: " + ec.message());
  if (!made) {
    if (!fs::is_directory(fs::symlink_status(folder, ec)))
      throw io::IoError(folder.string() + ": exists and is not a coarse level's folder: it is left alone; remove or rename it");
    if (!resume)
      throw io::IoError(folder.string() +
                        ": an interrupted run is in the way: pass --resume to continue it, or remove the folder");
  }
  auto lock = std::make_unique<io::FolderLock>(folder);
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    if (std::find(std::begin(kFolderNames), std::end(kFolderNames), name) == std::end(kFolderNames))
      throw io::IoError(folder.string() + ": holds files this tool did not make (" + name +
                        "): it is left alone; remove or rename it");
  }
  return lock;
}

void remove_folder(const fs::path& folder) {
  std::error_code ec;
  for (const char* name : kFolderNames) {
    if (fs::is_directory(fs::symlink_status(folder / name, ec))) remove_folder(folder / name);
    fs::remove(folder / name, ec);
  }
  fs::remove(folder, ec);  // only when empty
}

}  // namespace

}  // namespace coarse

std::filesystem::path coarse_folder_name(const std::filesystem::path& output) { return std::filesystem::path(partial_name(output).string() + ".coarse"); }

void remove_coarse_folder(const std::filesystem::path& output) { coarse::remove_folder(coarse_folder_name(output)); }

namespace coarse {

namespace {

// A stage's file: made (as `name`.tmp, renamed when complete) unless there, and checked
// against `key` when there.
template <class Make>
void make_stage_file(const fs::path& folder, const std::string& name, const std::string& key, Make&& make) {
  const fs::path file = folder / name;
  std::error_code ec;
  if (fs::exists(file, ec)) {
    const h5::File f = h5::File::open(file, false);
    if (!f.has_attribute("/", kKey) || f.string_attribute("/", kKey) != key)
      throw ParamError(folder.string() +
                       " was started with other parameters or another input: run with the run's values, or remove "
                       "the folder to start again");
    return;
  }
  const fs::path temporary = folder / (name + ".tmp");
  make(temporary);
  {
    h5::File f = h5::File::open(temporary, true);
    f.set_attribute("/", kKey, key);
    f.flush();
  }
  fs::rename(temporary, file, ec);
  if (ec) throw io::IoError(file.string() + ": cannot rename the finished stage into place: " + ec.message());
}

// Runs `stage` on rank 0; every rank throws when it threw (rank 0 its exception, the others
// its message).
template <class Stage>
void on_first_rank(Ranks& ranks, Stage&& stage) {
  std::exception_ptr error;
  std::string message;
  if (ranks.rank() == 0) {
    try {
      stage();
    } catch (const std::exception& e) {
      error = std::current_exception();
      message = e.what();
    }
  }
  if (ranks.sum(error ? 1 : 0) == 0) return;
  message = ranks.from_first(message);
  if (error) std::rethrow_exception(error);
  throw ParamError(message);
}

std::uint64_t point_count_of(const fs::path& file) { return point_count(h5::File::open(file, false)); }

int steps_of_finished_run(const fs::path& file) {
  const auto state = h5::File::open(file, false).dataset(layout::run_state).read_all<std::int64_t>();
  return static_cast<int>(state[detail::kCompletedSteps]);
}

}  // namespace

// `nested`: a coarse level's own coarse level, which runs whatever the noise (as in core).
OutOfCoreReport smooth_with_coarse_level(const fs::path& input, const fs::path& output, const SmoothParams& params,
                                         const OutOfCoreOptions& options, bool nested) {
  params.validate();
  require(options.neighbor_reference.empty(), "a coarse level cannot take neighbourhoods from a reference cloud");
  require(options.start_positions.empty(), "a coarse level cannot start from other positions");
  Ranks single;
  Ranks& ranks = options.ranks != nullptr ? *options.ranks : single;
  const CoarseLevelParams& c = *params.coarse;
  const auto t0 = std::chrono::steady_clock::now();
  SmoothParams plain = params;
  plain.coarse.reset();
  // Whether the input's noise calls for it, and the cells of its sample (as in core).
  const NoiseEstimate noise = detail::Run(input, output, plain, options).measure_noise();
  if (!nested && !(noise.ratio >= c.min_noise_ratio)) return detail::Run(input, output, plain, options).run();
  TileTable tiles;
  {
    const h5::File in = h5::File::open(input, false);
    tiles = read_tile_table(in);
  }
  const Box all = cloud_bounds(tiles);
  const MortonGrid grid = morton_grid(Vec3(all[0], all[1], all[2]), Vec3(all[3], all[4], all[5]));
  const CoarseCells cells = coarse_cells(grid, c.cell_spacings * noise.spacing);
  const auto stage_progress = [&](const char* phase) {
    return [&options, phase](std::uint64_t done, std::uint64_t total) {
      if (options.progress) options.progress(phase, done, total);
    };
  };

  const fs::path folder = coarse_folder_name(output);
  std::unique_ptr<io::FolderLock> lock;
  std::uint64_t coarse_points = 0;
  std::string key;  // rank 0's
  on_first_rank(ranks, [&] {
    lock = open_folder(folder, options.resume);
    key = stage_key(input, params);
    make_stage_file(folder, "sample.h5", key, [&](const fs::path& file) {
      write_coarse_sample(input, file, cells, c.ratio, options.memory_budget, stage_progress("coarse sample"));
    });
    coarse_points = point_count_of(folder / "sample.h5");
  });
  coarse_points = ranks.sum(coarse_points);
  // Too few for a surface of their own (the automatic k needs a few dozen): no coarse level.
  if (coarse_points < 64) {
    if (ranks.rank() == 0) {
      lock.reset();
      remove_folder(folder);
    }
    return detail::Run(input, output, plain, options).run();
  }

  // The flow on the coarse sample: free, without the finish, its k measured on it.
  SmoothParams coarse_params = plain;
  coarse_params.finish.reset();
  coarse_params.placement = Placement::Free;
  coarse_params.neighbors.k = 0;
  OutOfCoreOptions coarse_options = options;
  coarse_options.resume = true;  // the folder is the run's: a partial run there is its own
  coarse_options.attributes = true;
  coarse_options.progress = nullptr;
  if (options.progress)
    coarse_options.progress = [&options](const std::string& phase, std::uint64_t done, std::uint64_t total) {
      options.progress("coarse " + phase, done, total);
    };
  OutOfCoreReport report;
  std::vector<CoarseLevelReport> levels{{coarse_points, 0}};
  std::error_code ec;
  if (fs::exists(folder / "coarse.h5", ec)) {
    levels[0].steps = steps_of_finished_run(folder / "coarse.h5");
  } else {
    OutOfCoreReport coarse_report;
    try {
      if (c.levels > 1) {
        coarse_params.coarse = c;
        coarse_params.coarse->levels = c.levels - 1;
        coarse_report = smooth_with_coarse_level(folder / "sample.h5", folder / "coarse.h5", coarse_params,
                                                 coarse_options, true);
      } else {
        coarse_report = detail::Run(folder / "sample.h5", folder / "coarse.h5", coarse_params, coarse_options).run();
      }
    } catch (const BudgetError& e) {
      // Named by the user's input, not by the run's own sample.
      throw BudgetError("the memory budget of " + size_text(options.memory_budget, false) +
                            " is too small for the coarse level of " + input.string() + " (its run on the coarse sample needs " +
                            size_text(e.needed, true) + "): give a larger budget; --resume continues the run",
                        e.budget, e.needed);
    }
    if (!coarse_report.finished) {
      report.tiles = tiles.size();
      report.points = tiles.offsets.back();
      return report;  // stopped (OutOfCoreOptions::stop_after_steps)
    }
    levels[0].steps = coarse_report.steps;
    levels.insert(levels.end(), coarse_report.coarse_levels.begin(), coarse_report.coarse_levels.end());
  }

  on_first_rank(ranks, [&] {
    make_stage_file(folder, "start.h5", key, [&](const fs::path& file) {
      const double first_halo = std::max(4.0 * noise.spacing * std::sqrt(static_cast<double>(c.ratio)), 1e-300);
      write_moved_points(input, folder / "sample.h5", folder / "coarse.h5", file, grid, c.interpolation_k, first_halo,
                         options.memory_budget, stage_progress("coarse moves"));
    });
  });
  ranks.barrier();
  const double seconds_coarse = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Every point then takes fine_steps steps from where the coarse level left it, on
  // neighbourhoods of those positions; the finish places the input points.
  SmoothParams fine = plain;
  if (fine.finish) fine.finish = finish_after(params, true);
  fine.steps = c.fine_steps;
  fine.stop_lambda_ratio = 0.0;
  fine.stop_plateau = 0.0;
  OutOfCoreOptions fine_options = options;
  fine_options.start_positions = folder / "start.h5";
  report = detail::Run(input, output, fine, fine_options).run();
  report.coarse_levels = std::move(levels);
  report.seconds_coarse = seconds_coarse;
  if (report.finished && ranks.rank() == 0) {
    lock.reset();
    remove_folder(folder);
  }
  return report;
}

}  // namespace coarse

}  // namespace pointfair::tiles
