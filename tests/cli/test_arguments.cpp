// ArgumentParser (tools/cli/arguments.hpp): the option tables parsed by CLI11.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "cli/arguments.hpp"

namespace pointfair::cli {
namespace {

// A command with two positionals, a flag that resets a value, and options in every group.
struct Parsed {
  std::string in, out;
  int steps = 150;
  std::vector<std::string> applied;
  bool json = false;
};

ArgumentParser make_parser(Parsed& p) {
  ArgumentParser parser("pointfair test", "A command for the tests.");
  parser.positional("IN", "Input.", &p.in);
  parser.positional("OUT", "Output.", &p.out);
  parser.flag("json", "Summary on stdout.", [&p] { p.json = true; });
  parser.group(OptionGroup::Advanced);
  parser.value("tune", "F", "Fine tuning. Default 1.", [&p](std::string_view v) { p.applied.push_back(std::string(v)); });
  parser.group(OptionGroup::Method);
  parser.flag("paper", "Reset --steps to 100.", [&p] { p.steps = 100; });
  parser.value("steps", "N", "Steps. Default 150.", [&p](std::string_view v) { p.steps = parse_int(v, "--steps"); });
  parser.example("pointfair test in.ply out.ply --steps 3");
  return parser;
}

std::string usage_error(const std::vector<std::string>& args) {
  Parsed p;
  ArgumentParser parser = make_parser(p);
  try {
    parser.parse(args);
  } catch (const UsageError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Arguments, OptionsApplyInTheOrderGiven) {
  Parsed a;
  ASSERT_TRUE(make_parser(a).parse({"in.ply", "--steps", "3", "out.ply", "--paper"}));
  EXPECT_EQ(a.in, "in.ply");
  EXPECT_EQ(a.out, "out.ply");
  EXPECT_EQ(a.steps, 100);
  Parsed b;
  ASSERT_TRUE(make_parser(b).parse({"--paper", "--steps=3", "in.ply", "out.ply", "--json"}));
  EXPECT_EQ(b.steps, 3);
  EXPECT_TRUE(b.json);
  Parsed c;
  ASSERT_TRUE(make_parser(c).parse({"in.ply", "out.ply", "--tune", "1", "--tune=-2", "--tune", "-0.5"}));
  EXPECT_EQ(c.applied, (std::vector<std::string>{"1", "-2", "-0.5"}));
  EXPECT_FALSE(c.json);
}

TEST(Arguments, BadCommandLinesNameTheOptionOrArgument) {
  EXPECT_EQ(usage_error({"in", "out", "--bogus"}), "pointfair test: unknown option '--bogus' (see --help)");
  EXPECT_EQ(usage_error({"in", "out", "--bogus=3"}), "pointfair test: unknown option '--bogus' (see --help)");
  EXPECT_EQ(usage_error({"in", "out", "extra"}), "pointfair test: unexpected argument 'extra' (see --help)");
  EXPECT_EQ(usage_error({"in"}), "pointfair test: missing argument OUT (see --help)");
  EXPECT_EQ(usage_error({"in", "out", "--json=yes"}), "pointfair test: --json takes no value");
  EXPECT_EQ(usage_error({"in", "out", "--steps", "x"}), "--steps expects a whole number, got 'x'");
  EXPECT_NE(usage_error({"in", "out", "--steps"}).find("--steps"), std::string::npos);
  EXPECT_NE(usage_error({"in", "out", "--steps"}).find("missing"), std::string::npos);
}

TEST(Arguments, HelpListsTheGroupsInOrderAndTheExamples) {
  Parsed p;
  ArgumentParser parser = make_parser(p);
  testing::internal::CaptureStdout();
  EXPECT_FALSE(parser.parse({"--help"}));
  const std::string help = testing::internal::GetCapturedStdout();
  EXPECT_EQ(help, parser.help());
  EXPECT_EQ(help.rfind("usage: pointfair test [options] IN OUT\n\nA command for the tests.\n", 0), 0u) << help;
  const std::size_t common = help.find("\ncommon options:\n  -h, --help\n      Show this text.\n  --json\n");
  const std::size_t method = help.find("\nmethod options:\n  --paper\n      Reset --steps to 100.\n"
                                       "  --steps N\n      Steps. Default 150.\n");
  const std::size_t advanced = help.find("\nadvanced options:\n  --tune F\n      Fine tuning. Default 1.\n");
  const std::size_t examples = help.find("\nexamples:\n  pointfair test in.ply out.ply --steps 3\n");
  ASSERT_NE(common, std::string::npos) << help;
  ASSERT_NE(method, std::string::npos) << help;
  ASSERT_NE(advanced, std::string::npos) << help;
  ASSERT_NE(examples, std::string::npos) << help;
  EXPECT_LT(common, method);
  EXPECT_LT(method, advanced);
  EXPECT_LT(advanced, examples);
  EXPECT_LT(help.find("\narguments:\n  IN\n      Input.\n  OUT\n"), common);
}

TEST(Arguments, TheTableIsKnownByName) {
  Parsed p;
  const ArgumentParser parser = make_parser(p);
  EXPECT_TRUE(parser.has("steps"));
  EXPECT_FALSE(parser.has("help"));
  EXPECT_TRUE(parser.is_flag("paper"));
  EXPECT_FALSE(parser.is_flag("steps"));
  EXPECT_EQ(parser.names(), (std::vector<std::string>{"json", "tune", "paper", "steps"}));
}

}  // namespace
}  // namespace pointfair::cli
