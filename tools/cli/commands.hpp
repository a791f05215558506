#pragma once
// The pointfair subcommands. Each takes its arguments (after the command name) and returns
// the process exit code; errors are thrown and mapped to exit codes in main.
#include <cstdint>
#include <string>
#include <vector>

namespace pointfair::cli {

using Args = std::vector<std::string>;

int run_smooth(const Args& args);
int run_curvature(const Args& args);
int run_demo(const Args& args);
int run_generate(const Args& args);
int run_import(const Args& args);
int run_export(const Args& args);
/// True when a smooth command line asks for an out-of-core run (an .h5 argument,
/// --memory-budget or --resume); run_smooth then hands over to run_smooth_out_of_core.
bool wants_out_of_core(const Args& args);
int run_smooth_out_of_core(const Args& args);
class ArgumentParser;
/// --memory-budget SIZE and --resume, as `smooth` lists them in its help whichever run it
/// parses for: into *budget and *resume (either may be null: the in-core parser, which only
/// sees them under --help, the command line having gone to the out-of-core run otherwise).
void add_budget_options(ArgumentParser& parser, std::uint64_t* budget, bool* resume);
int run_eval(const Args& args);
int run_render(const Args& args);
int run_info(const Args& args);

}  // namespace pointfair::cli
