// pointfair import IN OUT.h5: a point file into the tiled HDF5 scan container.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "commands.hpp"
#include "json_writer.hpp"
#include "out_of_core.hpp"
#include "run_support.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/version.hpp"

namespace pointfair::cli {

int run_import(const Args& args) {
  std::string input, output;
  std::uint64_t budget = std::uint64_t{256} << 20;
  std::uint64_t tile_points = 0;
  double cell_size = 0.0;
  tiles::ImportOptions options;
  bool json = false, quiet = false;
  ArgumentParser parser("pointfair import",
                        "Writes a point file into a tiled HDF5 scan container (see the README: "
                        "positions, every attribute, original indices, a tile table) for "
                        "out-of-core runs. LAZ input must be decompressed to LAS first.");
  parser.positional("IN", "Input point file (.ply, .las, .xyz, .txt, .pts, .csv).", &input);
  parser.positional("OUT", "Output container (.h5); written under a temporary name and renamed.", &output);
  parser.value("memory-budget", "SIZE",
               "Memory budget of later runs (e.g. 256M, 2G): sets the tile size. Default 256M.",
               [&](std::string_view v) { budget = parse_size(v, "--memory-budget"); });
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
  parser.flag("json", "Print a machine-readable summary (JSON) on stdout.", [&] { json = true; });
  parser.flag("quiet", "No summary on stderr.", [&] { quiet = true; });
  if (!parser.parse(args)) return 0;
  if (!is_container_path(output)) throw UsageError("pointfair import: OUT must be a .h5 file, got '" + output + "'");
  io::require_distinct(input, output);

  const auto t0 = std::chrono::steady_clock::now();
  const io::PointTable table = read_input(input, quiet);
  options.tiling.max_tile_points = tile_points > 0 ? tile_points : tile_points_for_budget(budget, 16);
  options.tiling.cell_size = cell_size;
  options.source_name = std::filesystem::path(input).filename().string();
  options.source_size = std::filesystem::file_size(input);
  tiles::write_container(output, table, options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const tiles::TileTable tiles = tiles::read_tile_table(tiles::h5::File::open(output, false));
  if (!quiet)
    std::fprintf(stderr, "import: %zu points, %zu attributes, %zu tiles in %.2f s -> %s\n", table.size(),
                 table.attributes.size(), tiles.size(), seconds, output.c_str());
  if (json) {
    JsonObject j;
    j.add("command", "import").add("version", version()).add("input", input).add("output", output);
    j.add("points", table.size()).add("attributes", table.attributes.size()).add("tiles", tiles.size());
    j.add("max_tile_points", static_cast<std::size_t>(options.tiling.max_tile_points)).add("seconds", seconds);
    std::cout << j.str() << std::endl;
  }
  return 0;
}

}  // namespace pointfair::cli
