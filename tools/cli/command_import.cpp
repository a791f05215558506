// pointfair import IN OUT.h5: a point file into the tiled HDF5 scan container.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "commands.hpp"
#include "interrupt.hpp"
#include "json_writer.hpp"
#include "out_of_core.hpp"
#include "point_folder_run.hpp"
#include "run_support.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/tiles/budget.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/import.hpp"

namespace pointfair::cli {

int run_import(const Args& args) {
  std::string input, output;
  std::uint64_t budget = tiles::kDefaultMemoryBudget;
  std::uint64_t tile_points = 0;
  double cell_size = 0.0;
  tiles::ImportOptions options;
  bool json = false, quiet = false;
  ArgumentParser parser("pointfair import",
                        "Writes a point file into a tiled HDF5 scan container (docs/out-of-core.md: "
                        "positions, every attribute, original indices, a tile table) for "
                        "out-of-core runs.");
  parser.positional("IN",
                    "Input point file (.ply, .las, .laz, .xyz, .txt, .pts, .csv), or a folder whose .las "
                    ".laz .ply .xyz files become one cloud (their positions only; docs/tiles-folder.md).",
                    &input);
  parser.positional("OUT", "Output container (.h5); written under a temporary name and renamed.", &output);
  parser.value("memory-budget", "SIZE",
               "Memory budget (e.g. 256M, 2G): sets the tile size of later runs and bounds the import's "
               "own memory, which streams the file in three passes (at least 16M). Default 256M.",
               [&](std::string_view v) { budget = parse_size(v, "--memory-budget"); });
  parser.group(OptionGroup::Advanced);
  parser.value("tile-points", "N", "Most points per tile (kd tiles); overrides --memory-budget.",
               [&](std::string_view v) {
                 const int p = parse_int(v, "--tile-points");
                 if (p < 1) throw UsageError("--tile-points must be >= 1");
                 tile_points = static_cast<std::uint64_t>(p);
               });
  parser.value("tile-size", "LENGTH",
               "Regular grid tiles of this edge length (the cloud's length unit) instead of kd "
               "tiles; empty cells are kept as empty tiles.",
               [&](std::string_view v) {
                 cell_size = parse_double(v, "--tile-size");
                 if (!(cell_size > 0.0)) throw UsageError("--tile-size must be positive");
               });
  parser.value("chunk-rows", "N", "Rows per HDF5 chunk. Default 65536.", [&](std::string_view v) {
    const int c = parse_int(v, "--chunk-rows");
    if (c < 1) throw UsageError("--chunk-rows must be >= 1");
    options.chunk_rows = static_cast<std::uint64_t>(c);
  });
  parser.value("deflate", "LEVEL", "Deflate level 0..9 with shuffle (0 = none). Default 0.",
               [&](std::string_view v) {
                 options.deflate = parse_int(v, "--deflate");
                 if (options.deflate < 0 || options.deflate > 9) throw UsageError("--deflate must be in 0..9");
               });
  parser.group(OptionGroup::Common);
  parser.flag("json", "Print a machine-readable summary (JSON) on stdout.", [&] { json = true; });
  parser.flag("quiet", "No summary on stderr.", [&] { quiet = true; });
  parser.example("pointfair import city.las city.h5 --memory-budget 2G");
  parser.example("pointfair import city.las city.h5 --tile-points 500000 --deflate 4 --json");
  if (!parser.parse(args)) return 0;
  if (!tiles::is_container_path(output)) throw UsageError("pointfair import: OUT must be a .h5 file, got '" + output + "'");
  io::require_distinct(input, output);
  if (std::filesystem::is_directory(input)) input = without_trailing_separator(input).string();

  const auto t0 = std::chrono::steady_clock::now();
  options.tiling.max_tile_points = tile_points > 0 ? tile_points : tiles::import_tile_points(budget);
  options.tiling.cell_size = cell_size;
  options.source_name = std::filesystem::path(input).filename().string();
  options.source_size = input_file_size(input);
  // Streams the file (three passes) within the budget: see tiles/import.hpp.
  tiles::StreamImportOptions stream;
  stream.container = options;
  stream.memory_budget = budget;
  stream.read.on_warning = [quiet](const std::string& message) {
    if (!quiet) std::fprintf(stderr, "warning: %s\n", message.c_str());
  };
  // SIGINT/SIGTERM stop the import between chunks: the temporary file is removed.
  stream.progress = [](const std::string&, std::uint64_t, std::uint64_t) { throw_if_interrupted(); };
  const tiles::StreamImportReport report = tiles::import_points(input, output, stream);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!quiet)
    std::fprintf(stderr, "import: %llu points, %zu attributes, %zu tiles in %.2f s (import memory %.1f MiB of %.1f MiB) -> %s\n",
                 static_cast<unsigned long long>(report.points), report.attributes, report.tiles, seconds,
                 static_cast<double>(report.peak_accounted_bytes) / (1 << 20), static_cast<double>(budget) / (1 << 20),
                 output.c_str());
  if (json) {
    JsonObject j;
    j.add("command", "import").add("version", version()).add("input", input).add("output", output);
    j.add("points", static_cast<std::size_t>(report.points)).add("attributes", report.attributes).add("tiles", report.tiles);
    j.add("max_tile_points", static_cast<std::size_t>(options.tiling.max_tile_points)).add("seconds", seconds);
    j.add("memory_budget_bytes", static_cast<std::size_t>(budget));
    j.add("peak_accounted_bytes", static_cast<std::size_t>(report.peak_accounted_bytes));
    std::cout << j.str() << std::endl;
  }
  return 0;
}

}  // namespace pointfair::cli
