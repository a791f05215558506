// One definition of the defaults: what `pointfair smooth --help` and docs/command-line.md's option
// table say each option defaults to is what SmoothParams{} (the library's defaults, which
// the command runs) holds. A default changed in one place and not the others fails here.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "pointfair/smooth.hpp"

namespace pointfair {
namespace {

std::string text(double value) {
  std::ostringstream s;
  s << value;
  return s.str();
}

// Option name -> its default as the help and docs/command-line.md write it, from SmoothParams{}.
std::map<std::string, std::string> library_defaults() {
  const SmoothParams p;
  const QuadricProjectionParams q = *p.finish;
  return {
      {"k", p.neighbors.k == 0 ? "auto" : text(p.neighbors.k)},
      {"eps", p.neighbors.eps == 0.0 ? "auto" : text(p.neighbors.eps)},
      {"eps-factor", text(p.neighbors.eps_auto_factor)},
      {"steps", text(p.steps)},
      {"tau", text(p.flow.tau)},
      {"flow", p.flow.flow == Flow::Anisotropic ? "aniso" : "iso"},
      {"cutoff", p.flow.cutoff == Cutoff::Sharp ? "sharp" : "continuous"},
      {"cutoff-origin", p.flow.cutoff_origin == CutoffOrigin::Plane ? "plane" : "point"},
      {"lambda", p.flow.lambda == 0.0 ? "auto" : text(p.flow.lambda)},
      {"lambda-schedule", p.lambda_every_step ? "every-step" : "once"},
      {"stop-lambda-ratio", text(p.stop_lambda_ratio)},
      {"stop-plateau", text(p.stop_plateau)},
      {"shrink-compensation", text(p.shrink_compensation)},
      {"momentum", text(p.momentum)},
      {"momentum-gate", text(p.momentum_gate)},
      {"lambda-factor", text(p.flow.lambda_auto_factor)},
      {"normal", p.flow.normal_estimator == NormalEstimator::Robust ? "robust" : "pca"},
      {"robust-seed", text(p.flow.robust.seed_neighbors)},
      {"robust-iterations", text(p.flow.robust.iterations)},
      {"robust-bound", text(p.flow.robust.inlier_bound)},
      {"robust-gate", text(p.flow.robust.gate)},
      {"rebuild-every", text(p.rebuild_interval)},
      {"edge-quotient", text(p.flow.features.quotient)},
      {"feature-threshold", p.flow.features.scale == FeatureScale::Spacing ? "auto" : "lambda"},
      {"feature-turn", text(p.flow.features.turn)},
      {"density-floor", text(p.flow.weingarten.density_floor)},
      {"weights", p.flow.weingarten.weights == AngularWeights::Paper ? "paper" : "uniform"},
      {"move", p.placement == Placement::AlongNormal ? "normal" : "free"},
      {"quadric-finish", p.finish ? "on" : "off"},
      {"quadric-k", text(q.k)},
      {"quadric-angle", text(q.normal_angle)},
      {"quadric-degree", text(q.degree)},
      {"quadric-passes", text(q.passes)},
      {"quadric-iterations", text(q.iterations)},
      {"quadric-early-degree", text(q.early_degree)},
      {"quadric-early-iterations", text(q.early_iterations)},
      {"quadric-curvature-reach", text(q.curvature_reach)},
      {"quadric-min-k", text(q.min_k)},
      {"coarse-level", p.coarse ? "on" : "off"},
      {"coarse-ratio", text(CoarseLevelParams{}.ratio)},
      {"coarse-cell", text(CoarseLevelParams{}.cell_spacings)},
      {"coarse-levels", text(CoarseLevelParams{}.levels)},
      {"coarse-fine-steps", text(CoarseLevelParams{}.fine_steps)},
      {"coarse-finish-passes", text(CoarseLevelParams{}.finish_passes)},
      {"coarse-min-noise", text(CoarseLevelParams{}.min_noise_ratio)},
  };
}

std::string run_help() {
  const std::string command = std::string(POINTFAIR_EXE) + " smooth --help";
  std::FILE* pipe = popen(command.c_str(), "r");
  EXPECT_NE(pipe, nullptr);
  std::string out;
  char buffer[4096];
  while (pipe != nullptr && std::fgets(buffer, sizeof buffer, pipe) != nullptr) out += buffer;
  if (pipe != nullptr) {
    EXPECT_EQ(pclose(pipe), 0);
  }
  return out;
}

// "  --name METAVAR\n      help\n" -> name -> help.
std::map<std::string, std::string> help_by_option(const std::string& help) {
  std::map<std::string, std::string> by_name;
  std::istringstream in(help);
  std::string line, name;
  while (std::getline(in, line)) {
    if (line.rfind("  --", 0) == 0) {
      name = line.substr(4, line.find(' ', 4) == std::string::npos ? std::string::npos : line.find(' ', 4) - 4);
    } else if (!name.empty() && line.rfind("      ", 0) == 0) {
      by_name[name] += line.substr(6);
    }
  }
  return by_name;
}

// The word after the last "Default " of a help text, without its closing full stop.
std::string stated_default(const std::string& help) {
  const std::size_t at = help.rfind("Default ");
  if (at == std::string::npos) return "";
  std::string word = help.substr(at + 8);
  word = word.substr(0, word.find_first_of(" ;,"));
  if (!word.empty() && word.back() == '.') word.pop_back();
  return word;
}

TEST(DefaultsText, SmoothHelpStatesTheLibraryDefaults) {
  const std::map<std::string, std::string> help = help_by_option(run_help());
  ASSERT_GT(help.size(), 30u);
  for (const auto& [name, value] : library_defaults()) {
    if (name == "quadric-finish") continue;  // a flag: "Default on" is checked below
    ASSERT_TRUE(help.count(name)) << "--" << name << " missing from smooth --help";
    EXPECT_EQ(stated_default(help.at(name)), value) << "--" << name << ": " << help.at(name);
  }
  EXPECT_NE(help.at("quadric-finish").find(SmoothParams{}.finish ? "Default on" : "Default off"), std::string::npos)
      << help.at("quadric-finish");
}

// The option table of docs/command-line.md: rows "| `--name ARG`, `--other ARG` | meaning | d1, d2 |".
TEST(DefaultsText, CommandLineDocOptionTableStatesTheLibraryDefaults) {
  std::ifstream readme(std::string(POINTFAIR_SOURCE_DIR) + "/docs/command-line.md");
  ASSERT_TRUE(readme) << "docs/command-line.md not found";
  const std::map<std::string, std::string> defaults = library_defaults();
  std::size_t checked = 0;
  std::string line;
  while (std::getline(readme, line)) {
    if (line.rfind("| `--", 0) != 0) continue;
    const std::size_t first_end = line.find(" | ");
    const std::size_t last_start = line.rfind(" | ");
    if (first_end == std::string::npos || last_start == first_end) continue;
    std::string value_cell = line.substr(last_start + 3);
    value_cell = value_cell.substr(0, value_cell.rfind(" |"));
    std::vector<std::string> names, values;
    const std::string names_cell = line.substr(2, first_end - 2);
    for (std::size_t at = names_cell.find("`--"); at != std::string::npos; at = names_cell.find("`--", at + 1)) {
      const std::size_t end = names_cell.find_first_of(" `", at + 3);
      names.push_back(names_cell.substr(at + 3, end - at - 3));
    }
    std::istringstream split(value_cell);
    for (std::string v; std::getline(split, v, ',');) values.push_back(v.substr(v.find_first_not_of(' ')));
    if (values.size() != names.size()) continue;  // a row whose defaults are not one per option
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (!defaults.count(names[i])) continue;
      EXPECT_EQ(values[i], defaults.at(names[i])) << "docs/command-line.md row of --" << names[i] << ": " << line;
      ++checked;
    }
  }
  EXPECT_GE(checked, 20u) << "the option table of docs/command-line.md was not found or not read";
}

}  // namespace
}  // namespace pointfair
