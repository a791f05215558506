#include "arguments.hpp"

#include <charconv>
#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include <CLI/CLI.hpp>

namespace pointfair::cli {

double parse_double(std::string_view text, std::string_view what) {
  double value = 0.0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end || std::isnan(value))
    throw UsageError(std::string(what) + " expects a number, got '" + std::string(text) + "'");
  return value;
}

int parse_int(std::string_view text, std::string_view what) {
  int value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end)
    throw UsageError(std::string(what) + " expects a whole number, got '" + std::string(text) + "'");
  return value;
}

namespace {

constexpr OptionGroup kGroups[] = {OptionGroup::Common, OptionGroup::Method, OptionGroup::Advanced};

std::string group_title(OptionGroup group) {
  switch (group) {
    case OptionGroup::Common: return "common options";
    case OptionGroup::Method: return "method options";
    case OptionGroup::Advanced: return "advanced options";
  }
  return "options";
}

// The help as the commands have always printed it ("  --name METAVAR" and the text on the next
// line, indented: tests and docs/command-line.md read it so), in CLI11's groups, in the order of
// kGroups, with the examples as the footer.
class HelpFormatter : public CLI::Formatter {
 public:
  explicit HelpFormatter(const std::vector<ArgumentParser::Option>& options) {
    for (const auto& o : options) metavars_["--" + o.name] = o.metavar;
  }

  std::string make_help(const CLI::App* app, std::string name, CLI::AppFormatMode) const override {
    std::ostringstream out;
    const auto positionals = app->get_options([](const CLI::Option* o) { return o->get_positional(); });
    out << "usage: " << name << " [options]";
    for (const CLI::Option* p : positionals) out << ' ' << p->get_name();
    out << "\n\n" << app->get_description() << "\n";
    if (!positionals.empty()) out << make_group("arguments", true, positionals);
    for (const std::string& group : app->get_groups()) {
      const auto options = app->get_options(
          [&group](const CLI::Option* o) { return o->get_group() == group && o->nonpositional(); });
      if (!options.empty()) out << make_group(group, false, options);
    }
    out << make_footer(app);
    return out.str();
  }

  std::string make_group(std::string group, bool is_positional, std::vector<const CLI::Option*> options) const override {
    std::string out = "\n" + group + ":\n";
    for (const CLI::Option* o : options) out += make_option(o, is_positional);
    return out;
  }

  std::string make_option(const CLI::Option* option, bool is_positional) const override {
    std::string line = "  ";
    if (is_positional) {
      line += option->get_name();
    } else {
      std::string names;
      for (const std::string& s : option->get_snames()) names += "-" + s + ", ";
      for (const std::string& l : option->get_lnames()) names += "--" + l + ", ";
      line += names.substr(0, names.size() - 2);
      const auto metavar = metavars_.find("--" + option->get_lnames().front());
      if (metavar != metavars_.end() && !metavar->second.empty()) line += " " + metavar->second;
    }
    return line + "\n      " + option->get_description() + "\n";
  }

  std::string make_footer(const CLI::App* app) const override {
    return app->get_footer().empty() ? std::string() : "\n" + app->get_footer() + "\n";
  }

 private:
  std::map<std::string, std::string> metavars_;
};

// CLI11's application for these options: every option may be given more than once (each use
// is applied, in order), unknown arguments are kept for our own message.
std::unique_ptr<CLI::App> make_app(const std::string& command, const std::string& summary,
                                   const std::vector<ArgumentParser::Option>& options,
                                   const std::vector<ArgumentParser::Positional>& positionals,
                                   const std::vector<std::string>& examples) {
  auto app = std::make_unique<CLI::App>(summary, command);
  app->formatter(std::make_shared<HelpFormatter>(options));
  app->allow_extras();
  app->set_help_flag("-h,--help", "Show this text.")->group(group_title(OptionGroup::Common));
  for (const auto& p : positionals) app->add_option(p.name, CLI::callback_t{}, p.help);
  for (const OptionGroup group : kGroups) {
    for (const auto& o : options) {
      if (o.group != group) continue;
      CLI::Option* option = o.apply_flag ? app->add_flag("--" + o.name)->description(o.help)
                                         : app->add_option("--" + o.name, CLI::callback_t{}, o.help);
      option->group(group_title(group))->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
      if (o.apply_flag) option->disable_flag_override();
      else option->type_name(o.metavar);
    }
  }
  if (!examples.empty()) {
    std::string footer = "examples:";
    for (const auto& e : examples) footer += "\n  " + e;
    app->footer(footer);
  }
  return app;
}

}  // namespace

ArgumentParser::ArgumentParser(std::string command, std::string summary)
    : command_(std::move(command)), summary_(std::move(summary)) {}

void ArgumentParser::value(std::string name, std::string metavar, std::string help,
                           std::function<void(std::string_view)> apply) {
  options_.push_back({std::move(name), std::move(metavar), std::move(help), std::move(apply), {}, group_});
}

void ArgumentParser::flag(std::string name, std::string help, std::function<void()> apply) {
  options_.push_back({std::move(name), "", std::move(help), {}, std::move(apply), group_});
}

void ArgumentParser::positional(std::string name, std::string help, std::string* target) {
  positionals_.push_back({std::move(name), std::move(help), target});
}

void ArgumentParser::example(std::string command_line) { examples_.push_back(std::move(command_line)); }

const ArgumentParser::Option* ArgumentParser::find(std::string_view name) const {
  for (const auto& o : options_)
    if (o.name == name) return &o;
  return nullptr;
}

std::vector<std::string> ArgumentParser::names() const {
  std::vector<std::string> out;
  for (const auto& o : options_) out.push_back(o.name);
  return out;
}

bool ArgumentParser::parse(const std::vector<std::string>& args) {
  // CLI11 would say "json was given a disallowed flag override".
  for (const std::string& arg : args) {
    const std::size_t eq = arg.find('=');
    if (arg.starts_with("--") && eq != std::string::npos && is_flag(std::string_view(arg).substr(2, eq - 2)))
      throw UsageError(command_ + ": " + arg.substr(0, eq) + " takes no value");
  }
  const auto app = make_app(command_, summary_, options_, positionals_, examples_);
  try {
    // CLI11 takes the arguments last first.
    std::vector<std::string> reversed(args.rbegin(), args.rend());
    app->parse(reversed);
  } catch (const CLI::CallForHelp&) {
    std::cout << app->help();
    return false;
  } catch (const CLI::ParseError& e) {
    // CLI11's own wording, which names the option and the problem ("--steps: 1 required N missing").
    throw UsageError(command_ + ": " + e.what() + " (see --help)");
  }
  if (const std::vector<std::string> extras = app->remaining(); !extras.empty()) {
    const std::string& extra = extras.front();
    if (extra.starts_with("-") && extra.size() > 1)
      throw UsageError(command_ + ": unknown option '" + extra.substr(0, extra.find('=')) + "' (see --help)");
    throw UsageError(command_ + ": unexpected argument '" + extra + "' (see --help)");
  }
  for (const auto& p : positionals_) {
    const CLI::Option* given = app->get_option(p.name);
    if (given->count() == 0) throw UsageError(command_ + ": missing argument " + p.name + " (see --help)");
    *p.target = given->results().front();
  }
  // In the order given on the command line: --paper, then the options that override it.
  std::map<const CLI::Option*, std::size_t> uses;
  for (const CLI::Option* given : app->parse_order()) {
    if (given->get_positional()) continue;
    const Option* option = find(given->get_lnames().front());
    if (option == nullptr) continue;  // --help
    const std::size_t use = uses[given]++;
    if (option->apply_flag) option->apply_flag();
    else option->apply_value(given->results().at(use));
  }
  return true;
}

std::string ArgumentParser::help() const {
  return make_app(command_, summary_, options_, positionals_, examples_)->help();
}

}  // namespace pointfair::cli
