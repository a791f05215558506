#include "out_of_core_rate.hpp"

#include <stdlib.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

#include "pointfair/common/parallel.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/tiles/budget.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/import.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"

namespace pointfair::bench {

namespace fs = std::filesystem;

OutOfCoreBench::OutOfCoreBench(const std::vector<Vec3>& cloud, int k, const OutOfCoreRateOptions& options)
    : options_(options) {
  std::string pattern = (fs::temp_directory_path() / "pointfair-throughput-XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("cannot create a temporary directory in " + fs::temp_directory_path().string());
  dir_ = pattern;
  container_ = dir_ / "cloud.h5";
  tile_points_ = options.tile_points > 0 ? options.tile_points : tiles::tile_points_for_budget(options.memory_budget, k);
  // The cloud as a binary PLY, imported as `pointfair import` does (streamed, within the budget).
  io::PointTable table;
  table.positions = cloud;
  const fs::path ply = dir_ / "cloud.ply";
  io::write_points(ply, table);
  tiles::StreamImportOptions import;
  import.container.tiling.max_tile_points = tile_points_;
  import.memory_budget = std::max(options.memory_budget, tiles::kMinImportBudget);
  tiles_ = tiles::import_points(ply, container_, import).tiles;
  fs::remove(ply);
}

OutOfCoreBench::~OutOfCoreBench() {
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

OutOfCoreRate OutOfCoreBench::run(const SmoothParams& params, const std::vector<Vec3>& expected) const {
  const fs::path output = dir_ / "run.h5";
  tiles::OutOfCoreOptions ooc;
  ooc.memory_budget = options_.memory_budget;
  ooc.temporal_block = options_.temporal_block;
  ooc.attributes = false;
  const tiles::OutOfCoreReport report = tiles::smooth_out_of_core(container_, output, params, ooc);
  OutOfCoreRate rate;
  rate.steps = report.steps;
  rate.seconds_steps = report.seconds_steps;
  rate.point_steps_per_second =
      report.seconds_steps > 0 ? static_cast<double>(report.points) * report.steps / report.seconds_steps : 0.0;
  rate.tiles = report.tiles;
  rate.neighbors_cached = report.neighbors_cached;
  rate.positions_held = report.positions_held;
  rate.halo_scratch = report.halo_scratch;
  rate.step_blocks = report.step_blocks;
  rate.tiles_in_flight = report.tiles_in_flight;
  if (!expected.empty()) {
    const io::PointTable result = tiles::read_container(output, {.original_order = true, .result_positions = true});
    rate.checked = true;
    rate.identical = result.positions.size() == expected.size() &&
                     std::memcmp(result.positions.data(), expected.data(), expected.size() * sizeof(Vec3)) == 0;
  }
  fs::remove(output);
  return rate;
}

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

std::string number(double x) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.6g", x);
  return buffer;
}

}  // namespace

OutOfCoreSection measure_out_of_core(const std::vector<Vec3>& cloud, int k, int cores, int repeats,
                                     const std::function<SmoothParams(Flow)>& params_for,
                                     const OutOfCoreRateOptions& options) {
  OutOfCoreSection section;
  section.options = options;
  const OutOfCoreBench bench(cloud, k, options);
  section.tile_points = bench.tile_points();
  section.tiles = bench.tiles();
  for (const Flow flow : {Flow::Isotropic, Flow::Anisotropic}) {
    SmoothParams params = params_for(flow);
    if (options.temporal_block > 1 && params.flow.lambda == 0.0 && params.lambda_every_step) {
      params.lambda_every_step = false;
      section.lambda_once = true;
    }
    for (int threads = 1; threads <= cores; ++threads) {
      set_thread_count(threads);
      std::vector<double> in_rates, out_rates, ratios;
      bool identical = true;
      for (int r = 0; r < std::max(1, repeats); ++r) {
        std::vector<Vec3> positions = cloud;
        const SmoothReport in = smooth(positions, params);
        const double in_rate = static_cast<double>(cloud.size()) * in.steps / in.seconds_steps;
        // The first pair also checks the result against the in-core one.
        const OutOfCoreRate out = bench.run(params, r == 0 ? positions : std::vector<Vec3>{});
        if (out.checked) identical = identical && out.identical;
        section.neighbors_cached = out.neighbors_cached;
        section.positions_held = out.positions_held;
        section.halo_scratch = out.halo_scratch;
        section.step_blocks = out.step_blocks;
        section.tiles_in_flight = out.tiles_in_flight;
        in_rates.push_back(in_rate);
        out_rates.push_back(out.point_steps_per_second);
        ratios.push_back(out.point_steps_per_second / in_rate);
      }
      section.rows.push_back({flow == Flow::Isotropic ? "iso" : "aniso", threads, median(in_rates),
                              median(out_rates), median(ratios), identical});
    }
  }
  set_thread_count(0);
  return section;
}

void print_out_of_core(const OutOfCoreSection& s) {
  std::printf("  out of core (container of %zu tiles of at most %llu points, --memory-budget %lluM, "
              "temporal block %d%s%s; lists %s, positions %s%s, %d tiles in flight), paired with in core:\n",
              s.tiles, static_cast<unsigned long long>(s.tile_points),
              static_cast<unsigned long long>(s.options.memory_budget >> 20), s.options.temporal_block,
              s.step_blocks ? " (blocks of one step: lists and rings from the block scratch)" : "",
              s.lambda_once ? ", lambda measured once in both runs" : "",
              s.neighbors_cached ? "kept in memory" : "re-read every step",
              s.positions_held ? "kept in memory (every step still written and committed)" : "re-read every step",
              s.halo_scratch ? ", halos from the halo scratch" : "", s.tiles_in_flight);
  for (const OutOfCoreRow& row : s.rows)
    std::printf("  %-5s step, %d thread%s  %10.3g point-steps/s out of core, %10.3g in core: %3.0f%%%s\n",
                row.flow.c_str(), row.threads, row.threads > 1 ? "s" : " ", row.out_of_core, row.in_core,
                100.0 * row.ratio, row.identical ? "" : "  RESULT DIFFERS FROM IN CORE");
}

std::uint64_t streamed_budget(std::uint64_t points) {
  return std::max<std::uint64_t>(std::uint64_t{16} << 20, points * 64);
}

std::string out_of_core_json(const OutOfCoreSection& s, const std::string& name) {
  std::string json = "\"" + name + "\": {\"memory_budget_bytes\": " + std::to_string(s.options.memory_budget) +
                     ", \"tile_points\": " + std::to_string(s.tile_points) + ", \"tiles\": " +
                     std::to_string(s.tiles) + ", \"temporal_block\": " + std::to_string(s.options.temporal_block) +
                     ", \"lambda_schedule\": \"" + (s.lambda_once ? "once" : "every_step") + "\"" +
                     ", \"neighbors_cached\": " + (s.neighbors_cached ? "true" : "false") +
                     ", \"positions_held\": " + (s.positions_held ? "true" : "false") +
                     ", \"halo_scratch\": " + (s.halo_scratch ? "true" : "false") +
                     ", \"step_blocks\": " + (s.step_blocks ? "true" : "false") +
                     ", \"tiles_in_flight\": " + std::to_string(s.tiles_in_flight) + ", \"steps_per_flow\": [";
  for (std::size_t i = 0; i < s.rows.size(); ++i) {
    const OutOfCoreRow& r = s.rows[i];
    json += std::string(i ? ", " : "") + "{\"flow\": \"" + r.flow + "\", \"threads\": " + std::to_string(r.threads) +
            ", \"point_steps_per_second\": " + number(r.out_of_core) +
            ", \"in_core_point_steps_per_second\": " + number(r.in_core) + ", \"ratio_to_in_core\": " +
            number(r.ratio) + ", \"bit_identical\": " + (r.identical ? "true" : "false") + "}";
  }
  return json + "]}";
}

}  // namespace pointfair::bench
