// pointfair_throughput: end-to-end speed of the method on a generated cloud, as a table and
// as JSON. Measures, in one run: neighbourhood build rate, point-steps per second of the
// isotropic and the anisotropic step (the paper's estimator) for 1..all threads with the CPU
// time each used, peak memory per point of an in-core run beyond the input, the time of a full
// default run, optionally the cost per point over several cloud sizes, and, when built with
// CGAL (POINTFAIR_QUALITY_CGAL=ON and libcgal-dev), CGAL's jet and bilateral smoothers on the
// same cloud with our anisotropic step's speed as a ratio to theirs.
//
//   pointfair_throughput [--points N] [--steps S] [--k K] [--repeats R] [--json FILE]
//                        [--sizes N1,N2,...] [--no-memory] [--no-cgal]
//                        [--neighbors-only [--kd-tree]]
//                        [--no-out-of-core | --out-of-core-only] [--ooc-budget MIB] [--ooc-tile-points N]
//                        [--ooc-temporal-block H]
//
// Out of core (out_of_core_rate.hpp): the cloud imported into a container in a temporary
// directory, iso and aniso steps run on it with a memory budget (default 256 MiB, the CLI's)
// for 1..all threads, each paired with an in-core run and reported as a ratio to it. Without
// --ooc-budget a second such section streams: a budget of 64 bytes a point (at least 16 MiB)
// keeps neither the lists nor the positions in memory between steps, as for a cloud larger
// than the memory ("out_of_core_streamed" in the JSON). That section runs temporal blocks of
// 4 steps unless --ooc-temporal-block says otherwise (for both sections; 1: single steps):
// the setting for such a cloud, with the lambda then measured once in both runs.
// --out-of-core-only measures those sections alone (no build rate, step table or full run).
//
// --neighbors-only times the neighbourhood build alone (the path build_neighborhoods takes;
// with --kd-tree the same lists through one k-d tree query per point, the old path) for
// 1..all threads and exits. Under `valgrind --tool=callgrind`, its instruction count minus
// that of --repeats 0, divided by points x repeats x thread counts, is the build's
// instructions per point, a figure the machine's load does not change.
//
// Memory is measured in a child process forked before the parent starts any thread or fills
// its heap: the child generates the cloud, returns its free heap to the system (malloc_trim),
// resets its peak resident set (/proc/self/clear_refs) and runs the stage; the figure is the
// peak resident set (VmHWM) minus the resident set before the stage. A process that had run
// other stages before would reuse their freed pages and under-count.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/neighbors/kd_tree.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "pointfair/smooth.hpp"

#include "out_of_core_rate.hpp"

#if defined(POINTFAIR_HAVE_CGAL)
#include "quality/cgal_peers.hpp"
#endif

namespace {

using namespace pointfair;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// CPU time of the whole process (all threads), seconds.
double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// A field of /proc/self/status in kB, or -1.
long long proc_status_kb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::string prefix = std::string(key) + ":";
  while (std::getline(in, line))
    if (line.rfind(prefix, 0) == 0) return std::atoll(line.c_str() + prefix.size());
  return -1;
}

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

// The paper's estimator (FlowParams{}: curvatures from the point itself, no shrinkage
// compensation) for `steps` steps, with no automatic stop, so that every run does the same
// number of steps.
SmoothParams step_params(Flow flow, int k, int steps) {
  SmoothParams params = paper_smooth_params();
  params.neighbors.k = k;
  params.flow = FlowParams{};
  params.flow.flow = flow;
  params.steps = steps;
  return params;
}

enum class Stage { Neighbors, Smooth };

// Peak resident bytes per point that `stage` adds to a process holding only the input cloud,
// measured in a forked child (see the file comment); negative if it could not be measured.
double stage_bytes_per_point(Stage stage, std::size_t points, int k) {
  int fds[2];
  if (pipe(fds) != 0) return -1.0;
  const pid_t pid = fork();
  if (pid < 0) return -1.0;
  if (pid == 0) {
    close(fds[0]);
    std::vector<Vec3> cloud = make_cloud(points);
#if defined(__GLIBC__)
    malloc_trim(0);
#endif
    const long long generated_peak = proc_status_kb("VmHWM");
    std::ofstream("/proc/self/clear_refs") << "5";
    const long long before = proc_status_kb("VmRSS");
    // clear_refs must have reset the peak to the current resident set (up to the few pages
    // the stream buffers touch), or the figure is void.
    const long long peak_now = proc_status_kb("VmHWM");
    const bool reset = peak_now <= before + 1024 && (peak_now < generated_peak || generated_peak <= before + 1024);
    if (stage == Stage::Neighbors) {
      const Neighborhoods nb = build_neighborhoods(cloud, {.k = k});
      if (nb.size() != points) _exit(3);
    } else {
      SmoothParams params = step_params(Flow::Anisotropic, k, 2);
      smooth(cloud, params);
    }
    const long long peak = proc_status_kb("VmHWM");
    const long long kb = reset && before >= 0 && peak >= 0 ? peak - before : -1;
    const std::string text = std::to_string(kb);
    const ssize_t written = write(fds[1], text.data(), text.size());
    _exit(written == static_cast<ssize_t>(text.size()) ? 0 : 4);
  }
  close(fds[1]);
  char buffer[64] = {};
  const ssize_t got = read(fds[0], buffer, sizeof buffer - 1);
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (got <= 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) return -1.0;
  const long long kb = std::atoll(buffer);
  return kb < 0 ? -1.0 : 1024.0 * static_cast<double>(kb) / static_cast<double>(points);
}

std::vector<std::size_t> parse_sizes(const std::string& text) {
  std::vector<std::size_t> sizes;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) sizes.push_back(std::strtoull(item.c_str(), nullptr, 10));
  return sizes;
}

std::string number(double x) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.6g", x);
  return buffer;
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t points = 1'000'000;
  int steps = 10, k = 16, repeats = 3;
  std::string json_path;
  std::vector<std::size_t> sizes;
  bool memory = true, cgal = true, neighbors_only = false, kd_tree = false;
  bool out_of_core = true, out_of_core_only = false;
  bench::OutOfCoreRateOptions ooc;
  bool temporal_given = false;
  bool budget_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--no-memory") memory = false;
    else if (a == "--no-cgal") cgal = false;
    else if (a == "--neighbors-only") neighbors_only = true;
    else if (a == "--kd-tree") kd_tree = true;
    else if (a == "--no-out-of-core") out_of_core = false;
    else if (a == "--out-of-core-only") out_of_core_only = true;
    else if (a == "--ooc-budget" && has_value) {
      ooc.memory_budget = std::strtoull(argv[++i], nullptr, 10) << 20;
      budget_given = true;
    }
    else if (a == "--ooc-tile-points" && has_value) ooc.tile_points = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--ooc-temporal-block" && has_value) {
      ooc.temporal_block = std::atoi(argv[++i]);
      temporal_given = true;
    }
    else if (a == "--points" && has_value) points = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--steps" && has_value) steps = std::atoi(argv[++i]);
    else if (a == "--k" && has_value) k = std::atoi(argv[++i]);
    else if (a == "--repeats" && has_value) repeats = std::atoi(argv[++i]);
    else if (a == "--json" && has_value) json_path = argv[++i];
    else if (a == "--sizes" && has_value) sizes = parse_sizes(argv[++i]);
    else {
      std::fprintf(stderr,
                   "usage: %s [--points N] [--steps S] [--k K] [--repeats R] [--json FILE] "
                   "[--sizes N1,N2,...] [--no-memory] [--no-cgal] [--neighbors-only [--kd-tree]]\n"
                   "       [--no-out-of-core | --out-of-core-only] [--ooc-budget MIB] [--ooc-tile-points N]\n"
                   "       [--ooc-temporal-block H]\n",
                   argv[0]);
      return 2;
    }
  }
  if (points < 100 || steps < 1 || k < 2 || repeats < (neighbors_only ? 0 : 1)) {
    std::fprintf(stderr, "%s: need --points >= 100, --steps >= 1, --k >= 2, --repeats >= 1\n", argv[0]);
    return 2;
  }

  // Memory first: the children must be forked before this process starts worker threads.
  double build_bytes = -1.0, smooth_bytes = -1.0;
  if (memory && !neighbors_only) {
    build_bytes = stage_bytes_per_point(Stage::Neighbors, points, k);
    smooth_bytes = stage_bytes_per_point(Stage::Smooth, points, k);
  }
  // What the in-core run holds during its steps beyond the input, counted from the types:
  // neighbour indices and counts, the second position buffer, the order and its inverse.
  const double held_bytes = static_cast<double>(k * sizeof(Index) + sizeof(std::uint16_t) +
                                                sizeof(Vec3) + 2 * sizeof(Index));

  const int cores = thread_count();
  const std::vector<Vec3> cloud = make_cloud(points);
  std::printf("pointfair %s throughput: %zu points (noisy cube, random order), k = %d, %d steps, "
              "median of %d runs\n\n", version(), points, k, steps, repeats);

  // The out-of-core section (out_of_core_rate.hpp); a failure is one line and exit status 1.
  // Without --ooc-budget, a second section streams: its budget (bench::streamed_budget) keeps
  // neither the lists nor the positions in memory, as for a cloud larger than the memory.
  bench::OutOfCoreRateOptions streamed = ooc;
  streamed.memory_budget = bench::streamed_budget(points);
  streamed.tile_points = 0;
  if (!temporal_given) streamed.temporal_block = bench::kStreamedTemporalBlock;
  const auto measure_ooc = [&](const bench::OutOfCoreRateOptions& options) -> std::optional<bench::OutOfCoreSection> {
    try {
      return bench::measure_out_of_core(cloud, k, cores, repeats,
                                        [&](Flow flow) { return step_params(flow, k, steps); }, options);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: out of core: %s\n", argv[0], e.what());
      return std::nullopt;
    }
  };
  if (out_of_core_only) {
    const std::optional<bench::OutOfCoreSection> section = measure_ooc(ooc);
    if (!section) return 1;
    bench::print_out_of_core(*section);
    std::optional<bench::OutOfCoreSection> streamed_section;
    if (!budget_given) {
      streamed_section = measure_ooc(streamed);
      if (!streamed_section) return 1;
      bench::print_out_of_core(*streamed_section);
    }
    std::string json = "{\"points\": " + std::to_string(points) + ", \"k\": " + std::to_string(k) +
                       ", \"steps\": " + std::to_string(steps) + ", \"cores\": " + std::to_string(cores) +
                       ", " + bench::out_of_core_json(*section);
    if (streamed_section) json += ", " + bench::out_of_core_json(*streamed_section, "out_of_core_streamed");
    json += "}";
    if (!json_path.empty()) std::ofstream(json_path) << json << "\n";
    std::printf("\n%s\n", json.c_str());
    return 0;
  }

  if (neighbors_only) {
    std::vector<Index> every(kd_tree ? points : 0);
    for (std::size_t i = 0; i < every.size(); ++i) every[i] = static_cast<Index>(i);
    for (int threads = 1; threads <= cores; ++threads) {
      set_thread_count(threads);
      std::vector<double> times;
      for (int r = 0; r < repeats; ++r) {
        const auto t0 = Clock::now();
        if (kd_tree) {
          const KdTree tree(cloud);
          const Neighborhoods nb = build_neighborhoods_kd_tree(tree, every, k, resolve_eps(cloud, tree, {.k = k}));
        } else {
          const Neighborhoods nb = build_neighborhoods(cloud, {.k = k});
        }
        times.push_back(seconds_since(t0));
      }
      std::printf("  neighbourhood build%s %10.3g points/s (%d thread%s)\n", kd_tree ? " (k-d tree)" : "",
                  times.empty() ? 0.0 : static_cast<double>(points) / median(times), threads,
                  threads > 1 ? "s" : "");
    }
    set_thread_count(0);
    return 0;
  }

  // Neighbourhood build rate, all threads.
  std::vector<double> build_times;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = Clock::now();
    const Neighborhoods nb = build_neighborhoods(cloud, {.k = k});
    build_times.push_back(seconds_since(t0));
  }
  const double build_rate = static_cast<double>(points) / median(build_times);

  // Step rates per flow and thread count (the time of the steps only, as smooth() reports it,
  // including the automatic lambda measured before each step), and the CPU time of the whole
  // call over its wall time (how many cores it kept busy).
  struct Row { std::string flow; int threads; double rate; double busy; };
  std::vector<Row> rows;
  for (const Flow flow : {Flow::Isotropic, Flow::Anisotropic}) {
    for (int threads = 1; threads <= cores; ++threads) {
      set_thread_count(threads);
      std::vector<double> rates, busy;
      for (int r = 0; r < repeats; ++r) {
        std::vector<Vec3> positions = cloud;
        const double cpu0 = cpu_seconds();
        const auto t0 = Clock::now();
        const SmoothReport report = smooth(positions, step_params(flow, k, steps));
        busy.push_back((cpu_seconds() - cpu0) / seconds_since(t0));
        rates.push_back(static_cast<double>(points) * report.steps / report.seconds_steps);
      }
      rows.push_back({flow == Flow::Isotropic ? "iso" : "aniso", threads, median(rates), median(busy)});
    }
  }
  set_thread_count(0);
  std::optional<bench::OutOfCoreSection> ooc_section, streamed_section;
  if (out_of_core) {
    ooc_section = measure_ooc(ooc);
    if (!ooc_section) return 1;
    if (!budget_given) {
      streamed_section = measure_ooc(streamed);
      if (!streamed_section) return 1;
    }
  }
  double aniso_all = 0.0;
  for (const Row& row : rows)
    if (row.flow == "aniso" && row.threads == cores) aniso_all = row.rate;

  // A full default run (the method's defaults, automatic stop included).
  std::vector<Vec3> positions = cloud;
  SmoothParams defaults;  // the automatic k included (neighborhood_size.hpp)
  const auto t0 = Clock::now();
  const SmoothReport full = smooth(positions, defaults);
  const double full_seconds = seconds_since(t0);

  // Cost per point over cloud sizes (all threads): flat means no superlinear stage.
  struct SizeRow { std::size_t points; double build_ns; double step_ns; };
  std::vector<SizeRow> size_rows;
  for (const std::size_t n : sizes) {
    if (n < 100) continue;
    const std::vector<Vec3> c = make_cloud(n);
    const auto b0 = Clock::now();
    const Neighborhoods nb = build_neighborhoods(c, {.k = k});
    const double build_s = seconds_since(b0);
    std::vector<Vec3> p = c;
    const SmoothReport report = smooth(p, step_params(Flow::Anisotropic, k, steps));
    size_rows.push_back({n, 1e9 * build_s / static_cast<double>(n),
                         1e9 * report.seconds_steps / (static_cast<double>(n) * report.steps)});
  }

  // CGAL's smoothers on the same cloud, one pass each (all threads).
  struct Peer { std::string name; double points_per_second; };
  std::vector<Peer> peers;
#if defined(POINTFAIR_HAVE_CGAL)
  if (cgal) {
    const auto j0 = Clock::now();
    const std::vector<Vec3> jet = quality::cgal_jet_smooth(cloud, k, 1);
    peers.push_back({"CGAL jet_smooth_point_set", static_cast<double>(points) / seconds_since(j0)});
    const auto b0 = Clock::now();
    const std::vector<Vec3> bilateral = quality::cgal_bilateral_smooth(cloud, k, 1);
    peers.push_back({"CGAL bilateral_smooth_point_set (+ PCA normals, MST orientation)",
                     static_cast<double>(points) / seconds_since(b0)});
  }
#else
  (void)cgal;
#endif

  std::printf("  neighbourhood build      %10.3g points/s (%d threads)\n", build_rate, cores);
  for (const auto& row : rows)
    std::printf("  %-5s step, %d thread%s  %10.3g point-steps/s   (CPU %.2f of %d)\n", row.flow.c_str(),
                row.threads, row.threads > 1 ? "s" : " ", row.rate, row.busy, row.threads);
  for (const char* flow : {"iso", "aniso"}) {
    double one = 0, all = 0;
    for (const auto& row : rows) {
      if (row.flow != flow) continue;
      if (row.threads == 1) one = row.rate;
      if (row.threads == cores) all = row.rate;
    }
    std::printf("  %-5s speed-up %d vs 1 thread: %.2fx\n", flow, cores, one > 0 ? all / one : 0.0);
  }
  if (ooc_section) bench::print_out_of_core(*ooc_section);
  if (streamed_section) bench::print_out_of_core(*streamed_section);
  std::printf("  full default run: automatic k = %d, %d steps%s, %.2f s\n", full.k, full.steps,
              full.stopped_early ? " (automatic stop)" : "", full_seconds);
  if (memory) {
    std::printf("  memory beyond the input (peak resident set of a fresh child process):\n"
                "    neighbourhood build %.0f bytes/point, in-core smooth %.0f bytes/point\n",
                build_bytes, smooth_bytes);
  }
  std::printf("  arrays the in-core steps hold beyond the input (counted): %.0f bytes/point\n", held_bytes);
  for (const auto& s : size_rows)
    std::printf("  %9zu points: neighbourhood build %6.0f ns/point, aniso step %5.0f ns/point-step\n",
                s.points, s.build_ns, s.step_ns);
  for (const auto& peer : peers)
    std::printf("  %s, k = %d, 1 pass: %.3g points/s; our aniso step is %.1fx faster\n",
                peer.name.c_str(), k, peer.points_per_second, aniso_all / peer.points_per_second);
#if !defined(POINTFAIR_HAVE_CGAL)
  std::printf("  CGAL peers: not built (configure with -DPOINTFAIR_QUALITY_CGAL=ON and libcgal-dev)\n");
#endif

  std::string json = "{\"points\": " + std::to_string(points) + ", \"k\": " + std::to_string(k) +
                     ", \"steps\": " + std::to_string(steps) + ", \"cores\": " + std::to_string(cores) +
                     ", \"neighbor_build_points_per_second\": " + number(build_rate) +
                     ", \"steps_per_flow\": [";
  for (std::size_t i = 0; i < rows.size(); ++i)
    json += std::string(i ? ", " : "") + "{\"flow\": \"" + rows[i].flow + "\", \"threads\": " +
            std::to_string(rows[i].threads) + ", \"point_steps_per_second\": " + number(rows[i].rate) +
            ", \"cpu_per_wall\": " + number(rows[i].busy) + "}";
  json += "], \"full_run_seconds\": " + number(full_seconds) +
          ", \"full_run_steps\": " + std::to_string(full.steps) + ", \"full_run_k\": " + std::to_string(full.k);
  if (memory)
    json += ", \"peak_bytes_per_point_neighbor_build\": " + number(build_bytes) +
            ", \"peak_bytes_per_point_smooth\": " + number(smooth_bytes);
  json += ", \"held_bytes_per_point_steps\": " + number(held_bytes) + ", \"sizes\": [";
  for (std::size_t i = 0; i < size_rows.size(); ++i)
    json += std::string(i ? ", " : "") + "{\"points\": " + std::to_string(size_rows[i].points) +
            ", \"build_ns_per_point\": " + number(size_rows[i].build_ns) +
            ", \"aniso_ns_per_point_step\": " + number(size_rows[i].step_ns) + "}";
  json += "], \"peers\": [";
  for (std::size_t i = 0; i < peers.size(); ++i)
    json += std::string(i ? ", " : "") + "{\"name\": \"" + peers[i].name + "\", \"points_per_second\": " +
            number(peers[i].points_per_second) + ", \"aniso_ratio\": " +
            number(aniso_all / peers[i].points_per_second) + "}";
  json += "]";
  if (ooc_section) json += ", " + bench::out_of_core_json(*ooc_section);
  if (streamed_section) json += ", " + bench::out_of_core_json(*streamed_section, "out_of_core_streamed");
  json += "}";
  if (!json_path.empty()) std::ofstream(json_path) << json << "\n";
  std::printf("\n%s\n", json.c_str());
  return 0;
}
