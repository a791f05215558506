// pointfair_throughput: end-to-end speed of the method on a generated cloud, as a table and
// as JSON. Measures, in one run: neighbourhood build rate, point-steps per second of the
// isotropic and the anisotropic step for 1..all threads, peak memory per point of an in-core
// run beyond the input, and the time of a full default run.
//
//   pointfair_throughput [--points N] [--steps S] [--k K] [--json FILE]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "pointfair/parallel.hpp"
#include "pointfair/shapes.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/version.hpp"

namespace {

using namespace pointfair;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Resident set size and its peak, in bytes (Linux /proc).
long long proc_status_kb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::string prefix = std::string(key) + ":";
  while (std::getline(in, line))
    if (line.rfind(prefix, 0) == 0) return std::atoll(line.c_str() + prefix.size());
  return -1;
}
void reset_peak_rss() { std::ofstream("/proc/self/clear_refs") << "5"; }

// A noisy closed surface with sharp edges: area-uniform samples of a cube, noise 0.5% of the
// diagonal, in random order (the worst case for memory locality).
std::vector<Vec3> make_cloud(std::size_t n) {
  std::vector<Vec3> points = sample_mesh(cube_mesh(), n, 11).points;
  add_noise(points, 0.005 * bounding_box_diagonal(points), 12);
  return points;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t points = 1'000'000;
  int steps = 10, k = 16, repeats = 3;
  std::string json_path;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--points") points = std::strtoull(argv[i + 1], nullptr, 10);
    else if (a == "--steps") steps = std::atoi(argv[i + 1]);
    else if (a == "--k") k = std::atoi(argv[i + 1]);
    else if (a == "--repeats") repeats = std::atoi(argv[i + 1]);
    else if (a == "--json") json_path = argv[i + 1];
    else {
      std::fprintf(stderr, "usage: %s [--points N] [--steps S] [--k K] [--repeats R] [--json FILE]\n", argv[0]);
      return 2;
    }
  }
  const int cores = thread_count();
  const std::vector<Vec3> cloud = make_cloud(points);
  std::printf("pointfair %s throughput: %zu points (noisy cube, random order), k = %d, %d steps, "
              "median of %d runs\n\n", version(), points, k, steps, repeats);

  // Neighbourhood build rate, all threads.
  std::vector<double> build_times;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = Clock::now();
    const Neighborhoods nb = build_neighborhoods(cloud, {.k = k});
    build_times.push_back(seconds_since(t0));
  }
  const double build_rate = static_cast<double>(points) / median(build_times);

  // Step rates per flow and thread count (the time of the steps only, as smooth() reports it).
  struct Row { std::string flow; int threads; double rate; };
  std::vector<Row> rows;
  for (const Flow flow : {Flow::Isotropic, Flow::Anisotropic}) {
    for (int threads = 1; threads <= cores; ++threads) {
      set_thread_count(threads);
      std::vector<double> times;
      for (int r = 0; r < repeats; ++r) {
        std::vector<Vec3> positions = cloud;
        SmoothParams params;
        params.neighbors.k = k;
        params.flow.flow = flow;
        params.steps = steps;
        const SmoothReport report = smooth(positions, params);
        times.push_back(report.seconds_steps);
      }
      rows.push_back({flow == Flow::Isotropic ? "iso" : "aniso", threads,
                      static_cast<double>(points) * steps / median(times)});
    }
  }
  set_thread_count(0);

  // Peak memory of a full default run beyond the input cloud, and its time.
  std::vector<Vec3> positions = cloud;
  const long long rss_before = proc_status_kb("VmRSS");
  reset_peak_rss();
  SmoothParams defaults;
  defaults.neighbors.k = k;
  const auto t0 = Clock::now();
  const SmoothReport full = smooth(positions, defaults);
  const double full_seconds = seconds_since(t0);
  const long long peak = proc_status_kb("VmHWM");
  const double bytes_per_point = 1024.0 * static_cast<double>(peak - rss_before) / static_cast<double>(points);

  std::printf("  neighbourhood build      %10.3g points/s (%d threads)\n", build_rate, cores);
  for (const auto& row : rows)
    std::printf("  %-5s step, %d thread%s  %10.3g point-steps/s\n", row.flow.c_str(), row.threads,
                row.threads > 1 ? "s" : " ", row.rate);
  for (const char* flow : {"iso", "aniso"}) {
    double one = 0, all = 0;
    for (const auto& row : rows) {
      if (row.flow != flow) continue;
      if (row.threads == 1) one = row.rate;
      if (row.threads == cores) all = row.rate;
    }
    std::printf("  %-5s speed-up %d vs 1 thread: %.2fx\n", flow, cores, one > 0 ? all / one : 0.0);
  }
  std::printf("  full default run (%d steps): %.2f s; peak memory beyond the input: %.0f bytes/point\n",
              full.steps, full_seconds, bytes_per_point);

  std::string json = "{\"points\": " + std::to_string(points) + ", \"k\": " + std::to_string(k) +
                     ", \"steps\": " + std::to_string(steps) + ", \"cores\": " + std::to_string(cores) +
                     ", \"neighbor_build_points_per_second\": " + std::to_string(build_rate) +
                     ", \"steps_per_flow\": [";
  for (std::size_t i = 0; i < rows.size(); ++i)
    json += std::string(i ? ", " : "") + "{\"flow\": \"" + rows[i].flow + "\", \"threads\": " +
            std::to_string(rows[i].threads) + ", \"point_steps_per_second\": " + std::to_string(rows[i].rate) + "}";
  json += "], \"full_run_seconds\": " + std::to_string(full_seconds) +
          ", \"full_run_steps\": " + std::to_string(full.steps) +
          ", \"peak_bytes_per_point_beyond_input\": " + std::to_string(bytes_per_point) + "}";
  if (!json_path.empty()) std::ofstream(json_path) << json << "\n";
  std::printf("\n%s\n", json.c_str());
  return 0;
}
