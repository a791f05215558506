// pointfair: denoise point clouds with the anisotropic mean curvature flow of Lange & Polthier.
//
// Exit codes: 0 success; 1 unexpected failure; 2 bad command line or parameter;
// 3 input/output error (the message names the file); 130/143 interrupted by SIGINT/SIGTERM.
#include <csignal>
#include <cstdio>
#include <exception>
#include <iostream>
#include <new>
#include <string>
#include <vector>

#include "cli/arguments.hpp"
#include "cli/commands.hpp"
#include "cli/interrupt.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/point_table.hpp"

namespace {

constexpr const char* kUsage =
    "usage: pointfair COMMAND [options] ...\n"
    "\n"
    "Denoises point clouds while keeping sharp edges and corners, with the anisotropic mean\n"
    "curvature flow of Lange & Polthier, \"Anisotropic Smoothing of Point Sets\" (2005).\n"
    "\n"
    "commands:\n"
    "  smooth IN OUT      run the (an)isotropic flow on a point file\n"
    "  curvature IN OUT   write normals, principal curvatures and directions, feature classes\n"
    "  info FILE|DIR      describe a point file: format, count, bounds, CRS, attributes, noise\n"
    "  demo               the paper's octahedron experiment on a built-in input, into ./out\n"
    "  generate SHAPE OUT write a sampled test shape with noise (and its ground truth)\n"
    "  eval CLOUD         measure a cloud against ground truth (--truth)\n"
    "  render IN OUT.png  draw clouds headlessly (side-by-side panels)\n"
    "  import IN OUT.h5   write a point file into the tiled HDF5 container (out-of-core runs)\n"
    "  export IN.h5 OUT   write a container (and its smoothing run) to a point file\n"
    "  version            print the version\n"
    "\n"
    "examples:\n"
    "  pointfair smooth scan.ply smoothed.ply\n"
    "  pointfair smooth city.las city-smooth.las --memory-budget 2G --json\n"
    "\n"
    "'pointfair COMMAND --help' lists a command's options with units and defaults: the common\n"
    "ones first (input and output, colours, threads, memory budget, JSON, progress), then the\n"
    "method's, then the advanced ones, and examples.\n"
    "Exit codes: 0 ok, 1 unexpected failure, 2 bad arguments, 3 input/output error,\n"
    "130/143 interrupted by SIGINT/SIGTERM (between steps; no partial output is left).\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace pointfair;
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return 2;
  }
  const std::string command = argv[1];
  const cli::Args args(argv + 2, argv + argc);
  // SIGINT/SIGTERM end a run between steps with exit code 130/143 (cli/interrupt.hpp).
  cli::install_interrupt_handlers();
  // A file-size limit (ulimit -f) would end the process with SIGXFSZ at the first write past
  // it, with no message and temporaries left behind: ignored, the write fails with EFBIG
  // ("File too large"), which every writer reports naming the file and cleans up after.
  std::signal(SIGXFSZ, SIG_IGN);
  try {
    if (command == "smooth") return cli::run_smooth(args);
    if (command == "curvature") return cli::run_curvature(args);
    if (command == "demo") return cli::run_demo(args);
    if (command == "generate") return cli::run_generate(args);
    if (command == "import") return cli::run_import(args);
    if (command == "export") return cli::run_export(args);
    if (command == "eval") return cli::run_eval(args);
    if (command == "render") return cli::run_render(args);
    if (command == "info") return cli::run_info(args);
    if (command == "version" || command == "--version") {
      std::printf("pointfair %s\n", version());
      return 0;
    }
    if (command == "help" || command == "--help" || command == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    std::fprintf(stderr, "pointfair: unknown command '%s'\n\n%s", command.c_str(), kUsage);
    return 2;
  } catch (const cli::Interrupted& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return e.exit_code();
  } catch (const cli::UsageError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const ParamError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const io::IoError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 3;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
