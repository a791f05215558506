// pointfair_mpi: the out-of-core smooth of an HDF5 container on the ranks of an MPI job
// (mpirun / srun), over parallel HDF5. Same options and same result, to the bit, as
// `pointfair smooth IN.h5 OUT.h5` for any number of ranks. Built with -DPOINTFAIR_MPI=ON.
// `pointfair_mpi import IN OUT.h5` writes the container of `pointfair import`, to the bit,
// each rank reading its share of the input (tiles/import.hpp).
//
// Exit codes as pointfair's: 0 ok (or stopped by the test hook), 1 unexpected failure,
// 2 bad arguments or parameters, 3 input/output error. A rank that fails ends the whole job
// (MPI_Abort) with "pointfair_mpi: rank R of N: <problem>"; the committed steps stay in
// OUT.partial, and --resume continues them with any number of ranks.
//
// Every rank writes the neighbour lists, each step's positions and the attributes with
// collective parallel HDF5 transfers; the summary counts them.
//
// Test hooks (environment): POINTFAIR_MPI_STOP_AFTER_STEPS=S stops every rank after S steps
// committed by this call, as if killed; POINTFAIR_MPI_FAIL_AT=R:S makes rank R fail right
// after step S was committed (the others are then waiting in step S + 1);
// POINTFAIR_MPI_KILL_AT=R:S makes rank R kill itself with SIGKILL there instead (no message,
// no MPI_Abort: the launcher must notice and end the job).
#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/arguments.hpp"
#include "cli/method_options.hpp"
#include "cli/out_of_core.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/point_table.hpp"
#include "pointfair/tiles/budget.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/hdf5_file.hpp"
#include "pointfair/tiles/import.hpp"
#include "pointfair/tiles/mpi_ranks.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"

namespace {

using namespace pointfair;

constexpr const char* kProgram = "pointfair_mpi";

// "R:S" of the environment variable `name` (a test hook), or {-1, -1}.
std::pair<int, int> injected_failure(const char* name) {
  const char* v = std::getenv(name);
  if (v == nullptr) return {-1, -1};
  const std::string s = v;
  const std::size_t colon = s.find(':');
  if (colon == std::string::npos) throw cli::UsageError(std::string(name) + " must be RANK:STEP");
  return {cli::parse_int(s.substr(0, colon), name), cli::parse_int(s.substr(colon + 1), name)};
}

// pointfair smooth --classes and --returns put the smoothed points back among the others of the
// point file; this tool reads and writes containers only, which hold the points a run smooths.
void refuse_selection(cli::ArgumentParser& parser, const std::string& command) {
  for (const char* name : {"classes", "returns"}) {
    parser.value(name, "LIST",
                 "Not taken here: run pointfair smooth IN OUT --" + std::string(name) +
                     " LIST (with --memory-budget it runs out of core).",
                 [name, command](std::string_view) {
                   throw cli::UsageError(command + ": --" + name +
                                         " is not supported on containers: run pointfair smooth IN OUT --" + name +
                                         " LIST on the point file (out of core with --memory-budget)");
                 });
  }
}

int run(const std::vector<std::string>& args, tiles::Ranks& ranks) {
  std::string input, output;
  SmoothParams params;
  tiles::OutOfCoreOptions options;
  int threads = 0;
  bool quiet = false;
  cli::ArgumentParser parser(
      "pointfair_mpi smooth",
      "The out-of-core smooth of an HDF5 container (from pointfair import) on the ranks of an "
      "MPI job: each rank builds the neighbourhoods of and steps a balanced range of tiles, "
      "reading and writing the run file with parallel HDF5; every step is committed once all "
      "ranks wrote it. The result is bit-identical to pointfair smooth IN.h5 OUT.h5.");
  parser.positional("IN", "Input container (.h5).", &input);
  parser.positional("OUT", "Output container (.h5); OUT.partial holds the run until it ends.", &output);
  cli::add_method_options(parser, params);
  cli::add_finish_options(parser, params);
  parser.value("memory-budget", "SIZE", "Working memory of each rank (e.g. 256M, 2G). Default 256M.",
               [&](std::string_view v) { options.memory_budget = cli::parse_size(v, "--memory-budget"); });
  parser.flag("resume", "Continue the interrupted run in OUT.partial (same parameters, any number of ranks).",
              [&] { options.resume = true; });
  parser.value("threads", "N", "Worker threads per rank; 0 = all cores. Default 0.", [&](std::string_view v) {
    threads = cli::parse_int(v, "--threads");
    if (threads < 0) throw cli::UsageError("--threads must be >= 0");
  });
  parser.flag("quiet", "No progress or summary on stderr.", [&] { quiet = true; });
  refuse_selection(parser, "pointfair_mpi smooth");
  if (!parser.parse(args)) return 0;
  params.validate();
  set_thread_count(threads);
  if (const char* stop = std::getenv("POINTFAIR_MPI_STOP_AFTER_STEPS"))
    options.stop_after_steps = cli::parse_int(stop, "POINTFAIR_MPI_STOP_AFTER_STEPS");
  const auto [fail_rank, fail_step] = injected_failure("POINTFAIR_MPI_FAIL_AT");
  const auto [kill_rank, kill_step] = injected_failure("POINTFAIR_MPI_KILL_AT");
  const bool talk = !quiet && ranks.rank() == 0;
  options.ranks = &ranks;
  options.progress = [&](const std::string& phase, std::uint64_t done, std::uint64_t total) {
    if (phase != "step") return;
    if (ranks.rank() == fail_rank && static_cast<int>(done) == fail_step)
      throw io::IoError(output + ": failure injected by POINTFAIR_MPI_FAIL_AT after step " + std::to_string(done));
    if (ranks.rank() == kill_rank && static_cast<int>(done) == kill_step) std::raise(SIGKILL);
    if (talk) std::fprintf(stderr, "%s: step %llu/%llu\n", kProgram, static_cast<unsigned long long>(done),
                           static_cast<unsigned long long>(total));
  };
  const auto t0 = std::chrono::steady_clock::now();
  const tiles::OutOfCoreReport report = tiles::smooth_out_of_core(input, output, params, options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Every rank's collective HDF5 transfers, and those libhdf5 made independently after all.
  const tiles::h5::TransferCounts transfers = tiles::h5::transfer_counts();
  const std::uint64_t collective = ranks.sum(transfers.collective), fell_back = ranks.sum(transfers.fell_back);
  if (talk && (collective > 0 || fell_back > 0))
    std::fprintf(stderr, "%s: %llu collective HDF5 transfers over the ranks, %llu made independently%s\n", kProgram,
                 static_cast<unsigned long long>(collective), static_cast<unsigned long long>(fell_back),
                 fell_back > 0 ? (" (cause bits " + std::to_string(transfers.last_cause) + ")").c_str() : "");
  if (talk)
    std::fprintf(stderr,
                 "%s: %llu points in %zu tiles (halos %.1f%% of the points) on %d ranks, %d steps (%d resumed)%s "
                 "(k %d, lambda %.4g, eps %.4g) in "
                 "%.2f s (neighbours %.2f s, steps %.2f s, attributes %.2f s on rank 0) -> %s\n",
                 kProgram, static_cast<unsigned long long>(report.points), report.tiles,
                 report.points > 0 ? 100.0 * static_cast<double>(report.halo_points) / static_cast<double>(report.points)
                                   : 0.0,
                 ranks.size(), report.steps,
                 report.resumed_from, report.finished ? "" : ", stopped (POINTFAIR_MPI_STOP_AFTER_STEPS)",
                 report.k, report.lambda, report.eps, seconds, report.seconds_neighbors, report.seconds_steps,
                 report.seconds_attributes, report.finished ? output.c_str() : tiles::partial_name(output).c_str());
  return 0;
}

int run_import(const std::vector<std::string>& args, tiles::Ranks& ranks) {
  std::string input, output;
  std::uint64_t budget = tiles::kDefaultMemoryBudget, tile_points = 0;
  tiles::StreamImportOptions stream;
  bool quiet = false;
  cli::ArgumentParser parser(
      "pointfair_mpi import",
      "pointfair import on the ranks of an MPI job: each rank reads its share of a binary PLY or "
      "LAS file (rank 0 all of a text file) and writes its points into the container with "
      "parallel HDF5. The container is bit-identical to pointfair import's.");
  parser.positional("IN",
                    "Input point file (.ply, .las, .xyz, .txt, .pts, .csv), or a folder whose .las .laz "
                    ".ply .xyz files become one cloud of their positions (docs/tiles-folder.md).",
                    &input);
  parser.positional("OUT", "Output container (.h5); written under a temporary name and renamed.", &output);
  parser.value("memory-budget", "SIZE", "As pointfair import (per rank). Default 256M.",
               [&](std::string_view v) { budget = cli::parse_size(v, "--memory-budget"); });
  parser.value("tile-points", "N", "Most points per tile (kd tiles); overrides --memory-budget.",
               [&](std::string_view v) {
                 const int p = cli::parse_int(v, "--tile-points");
                 if (p < 1) throw cli::UsageError("--tile-points must be >= 1");
                 tile_points = static_cast<std::uint64_t>(p);
               });
  parser.value("tile-size", "LENGTH", "Regular grid tiles of this edge length.", [&](std::string_view v) {
    stream.container.tiling.cell_size = cli::parse_double(v, "--tile-size");
    if (!(stream.container.tiling.cell_size > 0.0)) throw cli::UsageError("--tile-size must be positive");
  });
  parser.value("chunk-rows", "N", "Rows per HDF5 chunk. Default 65536.", [&](std::string_view v) {
    const int c = cli::parse_int(v, "--chunk-rows");
    if (c < 1) throw cli::UsageError("--chunk-rows must be >= 1");
    stream.container.chunk_rows = static_cast<std::uint64_t>(c);
  });
  parser.value("deflate", "LEVEL", "Deflate level 0..9 (rank 0 compresses). Default 0.", [&](std::string_view v) {
    stream.container.deflate = cli::parse_int(v, "--deflate");
    if (stream.container.deflate < 0 || stream.container.deflate > 9)
      throw cli::UsageError("--deflate must be in 0..9");
  });
  parser.flag("quiet", "No summary on stderr.", [&] { quiet = true; });
  refuse_selection(parser, "pointfair_mpi import");
  if (!parser.parse(args)) return 0;
  if (!tiles::is_container_path(output))
    throw cli::UsageError("pointfair_mpi import: OUT must be a .h5 file, got '" + output + "'");
  io::require_distinct(input, output);
  const auto t0 = std::chrono::steady_clock::now();
  stream.container.tiling.max_tile_points = tile_points > 0 ? tile_points : tiles::import_tile_points(budget);
  // A folder's point files are imported as one cloud (tiles/import.hpp), named after the folder.
  std::filesystem::path named = std::filesystem::path(input).lexically_normal();
  if (!named.has_filename()) named = named.parent_path();
  stream.container.source_name = named.filename().string();
  stream.container.source_size = cli::input_file_size(input);
  stream.memory_budget = budget;
  const bool talk = !quiet && ranks.rank() == 0;
  // The last rank reads the end of the file, where the warnings about what follows the
  // points arise; the others would repeat those given when the file is opened.
  const bool warn = !quiet && ranks.rank() == ranks.size() - 1;
  stream.read.on_warning = [warn](const std::string& message) {
    if (warn) std::fprintf(stderr, "warning: %s\n", message.c_str());
  };
  stream.ranks = &ranks;
  const tiles::StreamImportReport report = tiles::import_points(input, output, stream);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (talk)
    std::fprintf(stderr, "%s import: %llu points, %zu attributes, %zu tiles on %d ranks in %.2f s -> %s\n", kProgram,
                 static_cast<unsigned long long>(report.points), report.attributes, report.tiles, ranks.size(),
                 seconds, output.c_str());
  return 0;
}

// The terminate handler: names this rank and the problem, and ends every rank of the job.
[[noreturn]] void on_failure() {
  std::string message = "unexpected failure";
  int code = 1;
  if (const std::exception_ptr error = std::current_exception()) {
    try {
      std::rethrow_exception(error);
    } catch (const cli::UsageError& e) {
      message = e.what();
      code = 2;
    } catch (const ParamError& e) {
      message = e.what();
      code = 2;
    } catch (const io::IoError& e) {
      message = e.what();
      code = 3;
    } catch (const std::exception& e) {
      message = std::string("unexpected failure: ") + e.what();
    } catch (...) {
    }
  }
  tiles::abort_job(kProgram, message, code);
}

}  // namespace

int main(int argc, char** argv) {
  tiles::MpiSession session(argc, argv);
  // A file-size limit: EFBIG ("File too large") reported naming the file, not a silent SIGXFSZ.
  std::signal(SIGXFSZ, SIG_IGN);
  const std::vector<std::string> all(argv + 1, argv + argc);
  if (all.empty() || (all[0] != "smooth" && all[0] != "import" && all[0] != "version" && all[0] != "--version")) {
    std::fprintf(stderr,
                 "usage: %s smooth IN.h5 OUT.h5 [options]   (%s smooth --help lists them)\n"
                 "       %s import IN OUT.h5 [options]\n",
                 kProgram, kProgram, kProgram);
    return 2;
  }
  if (all[0] != "smooth" && all[0] != "import") {
    std::printf("%s %s\n", kProgram, version());
    return 0;
  }
  // A failure ends the job from std::terminate: the exception is not caught, so the stack is
  // not unwound (unwinding would close the shared file, a collective call that the other
  // ranks, busy with their tiles, would never join).
  std::set_terminate(on_failure);
  tiles::MpiRanks ranks;
  try {
    const std::vector<std::string> rest(all.begin() + 1, all.end());
    return all[0] == "import" ? run_import(rest, ranks) : run(rest, ranks);
  } catch (const cli::UsageError& e) {
    // Every rank parses the same command line: all end here, before any file is open.
    if (ranks.rank() == 0) std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
