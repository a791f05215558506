// pointfair_default_run: what a user's first run costs. The default run of `pointfair smooth
// IN OUT` (the command itself, end to end: read, neighbourhoods, flow, finish, write), timed
// on a noisy sample of a mesh, against CGAL's jet_smooth_point_set (k 16, one pass; read and
// written through the same readers and writers) on the same file, alternating in one run; the
// median of the ratios, the time of each of our stages (the command's --json), and the cost
// per point over cloud sizes.
//
//   pointfair_default_run [--points N] [--noise PCT] [--mesh FILE.off] [--repeats R]
//                         [--threads T] [--sizes N1,N2,...] [--cli PATH] [--jet-k K]
//                         [--options "SMOOTH OPTIONS"]
//
// Without CGAL (POINTFAIR_QUALITY_CGAL=ON and libcgal-dev) only our side is timed.
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/mesh.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/shapes/shapes.hpp"

#if defined(POINTFAIR_HAVE_CGAL)
#include "quality/cgal_peers.hpp"
#endif

namespace {

namespace fs = std::filesystem;
using namespace pointfair;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// The number after "\"key\": " in a JSON text (the command's flat --json summary), or -1.
double json_number(const std::string& json, const std::string& key) {
  const std::string pattern = "\"" + key + "\": ";
  const std::size_t at = json.find(pattern);
  return at == std::string::npos ? -1.0 : std::strtod(json.c_str() + at + pattern.size(), nullptr);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct OurRun {
  double total = 0;  // wall time of the command, process start to exit
  std::map<std::string, double> stage;  // the command's own seconds per stage
  int steps = 0, k = 0;
};

// One run of `cli smooth in out --json --quiet --threads T OPTIONS`.
OurRun run_command(const std::string& cli, const fs::path& in, const fs::path& out, int threads,
                   const std::string& options, const fs::path& json) {
  const std::string command = cli + " smooth " + in.string() + " " + out.string() + " --json --quiet --threads " +
                              std::to_string(threads) + (options.empty() ? "" : " " + options) + " > " + json.string();
  const auto t0 = Clock::now();
  const int status = std::system(command.c_str());
  OurRun r;
  r.total = seconds_since(t0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("'" + command + "' failed with status " + std::to_string(status));
  const std::string text = slurp(json);
  // The stages' times are the members of the summary's "seconds" object (its "steps" member
  // before it is the step count).
  const std::size_t seconds_at = text.find("\"seconds\": {");
  const std::string seconds = seconds_at == std::string::npos ? std::string() : text.substr(seconds_at);
  for (const char* s : {"read", "coarse_level", "neighbors", "steps", "finish", "attributes", "write"})
    r.stage[s] = json_number(seconds, s);
  r.steps = static_cast<int>(json_number(text, "steps"));
  r.k = static_cast<int>(json_number(text, "k"));
  return r;
}

std::vector<Vec3> noisy_sample(const std::string& mesh_path, std::size_t n, double noise_percent) {
  const TriangleMesh mesh = mesh_path.empty() ? cube_mesh() : io::read_mesh(mesh_path);
  std::vector<Vec3> points = sample_mesh(mesh, n, 21).points;
  add_noise(points, noise_percent / 100.0 * bounding_box_diagonal(points), 22);
  return points;
}

std::vector<std::size_t> parse_sizes(const std::string& text) {
  std::vector<std::size_t> sizes;
  std::istringstream in(text);
  for (std::string item; std::getline(in, item, ',');) sizes.push_back(std::strtoull(item.c_str(), nullptr, 10));
  return sizes;
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t points = 1'000'000;
  double noise = 0.5;
  std::string mesh, cli = POINTFAIR_CLI, options;
  int repeats = 3, threads = 0, jet_k = 16;
  std::vector<std::size_t> sizes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--points" && has_value) points = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--noise" && has_value) noise = std::strtod(argv[++i], nullptr);
    else if (a == "--mesh" && has_value) mesh = argv[++i];
    else if (a == "--repeats" && has_value) repeats = std::atoi(argv[++i]);
    else if (a == "--threads" && has_value) threads = std::atoi(argv[++i]);
    else if (a == "--sizes" && has_value) sizes = parse_sizes(argv[++i]);
    else if (a == "--cli" && has_value) cli = argv[++i];
    else if (a == "--jet-k" && has_value) jet_k = std::atoi(argv[++i]);
    else if (a == "--options" && has_value) options = argv[++i];
    else {
      std::fprintf(stderr,
                   "usage: %s [--points N] [--noise PCT] [--mesh FILE.off] [--repeats R] [--threads T] "
                   "[--sizes N1,N2,...] [--cli PATH] [--jet-k K] [--options \"SMOOTH OPTIONS\"]\n",
                   argv[0]);
      return 2;
    }
  }
  if (points < 1000 || repeats < 1 || threads < 0 || !(noise >= 0.0)) {
    std::fprintf(stderr, "%s: need --points >= 1000, --repeats >= 1, --threads >= 0, --noise >= 0\n", argv[0]);
    return 2;
  }
  set_thread_count(threads);
  threads = thread_count();
  std::random_device rd;
  const fs::path dir = fs::temp_directory_path() / ("pointfair_default_run_" + std::to_string(rd()));
  fs::create_directories(dir);
  struct Cleanup {
    fs::path dir;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(dir, ec);
    }
  } cleanup{dir};
  try {
    std::printf("pointfair %s: the default run of `pointfair smooth IN OUT` on %zu points (%s, %.3g%% noise), "
                "%d threads, median of %d alternating runs\n\n",
                version(), points, mesh.empty() ? "cube mesh" : fs::path(mesh).filename().c_str(), noise, threads,
                repeats);
    const fs::path in = dir / "in.ply";
    io::PointTable table;
    table.positions = noisy_sample(mesh, points, noise);
    io::write_points(in, table);

    std::vector<double> ours, jets, ratios;
    std::map<std::string, std::vector<double>> stages;
    OurRun last;
    for (int r = 0; r < repeats; ++r) {
      last = run_command(cli, in, dir / "out.ply", threads, options, dir / "run.json");
      ours.push_back(last.total);
      for (const auto& [name, s] : last.stage) stages[name].push_back(s);
#if defined(POINTFAIR_HAVE_CGAL)
      // The peer end to end as well: read, smooth, write (our readers and writers).
      const auto t0 = Clock::now();
      io::PointTable peer = io::read_points(in);
      peer.positions = quality::cgal_jet_smooth(peer.positions, jet_k, 1);
      io::write_points(dir / "jet.ply", peer);
      jets.push_back(seconds_since(t0));
      ratios.push_back(ours.back() / jets.back());
#endif
    }
    const std::string run_name = options.empty() ? "defaults" : "defaults with " + options;
    std::printf("  ours (%s: automatic k %d, %d steps%s): %.2f s end to end\n", run_name.c_str(), last.k, last.steps,
                options.empty() ? ", finish, placement" : "", median(ours));
    for (const char* s : {"read", "coarse_level", "neighbors", "steps", "finish", "attributes", "write"})
      std::printf("    %-12s %8.2f s\n", s, median(stages[s]));
    if (!jets.empty()) {
      std::printf("  CGAL jet_smooth_point_set, k %d, 1 pass: %.2f s end to end\n", jet_k, median(jets));
      std::printf("  ratio ours / jet: %.2f (median of the %zu runs' ratios; target <= 1.0)\n", median(ratios),
                  ratios.size());
    } else {
      std::printf("  CGAL peers: not built (configure with -DPOINTFAIR_QUALITY_CGAL=ON and libcgal-dev)\n");
    }
    if (!sizes.empty()) std::printf("\n  cost per point of the default run over cloud sizes (one run each):\n");
    for (const std::size_t n : sizes) {
      io::PointTable t;
      t.positions = noisy_sample(mesh, n, noise);
      io::write_points(dir / "size.ply", t);
      const OurRun s = run_command(cli, dir / "size.ply", dir / "size_out.ply", threads, options, dir / "size.json");
      std::printf("    %10zu points: %.2f us/point end to end (coarse level %.2f, steps %.2f, finish %.2f; %d steps, k %d)\n",
                  n, 1e6 * s.total / static_cast<double>(n), 1e6 * s.stage.at("coarse_level") / static_cast<double>(n),
                  1e6 * s.stage.at("steps") / static_cast<double>(n), 1e6 * s.stage.at("finish") / static_cast<double>(n),
                  s.steps, s.k);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", argv[0], e.what());
    return 1;
  }
  return 0;
}
