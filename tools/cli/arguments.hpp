#pragma once
// The commands' option tables, parsed by CLI11: named options with a unit and a default in
// their help line, flags, and positional arguments, each in a group of the help (common
// options first, then the method's, then the advanced ones), and examples in the help's
// footer. Errors throw UsageError (exit code 2).
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace pointfair::cli {

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Parses a number; throws UsageError naming `what` when `text` is not one.
double parse_double(std::string_view text, std::string_view what);
int parse_int(std::string_view text, std::string_view what);

/// Where an option is listed in the help, in this order.
enum class OptionGroup {
  /// Input and output, colours, threads, memory budget, JSON, progress.
  Common,
  /// The method's main choices.
  Method,
  /// Fine tuning of the method and of the output format.
  Advanced,
};

class ArgumentParser {
 public:
  ArgumentParser(std::string command, std::string summary);

  /// The group of the options registered from now on (at first Common).
  void group(OptionGroup group) { group_ = group; }
  OptionGroup current_group() const { return group_; }
  /// An option taking a value: --name VALUE or --name=VALUE.
  void value(std::string name, std::string metavar, std::string help,
             std::function<void(std::string_view)> apply);
  /// A flag: --name.
  void flag(std::string name, std::string help, std::function<void()> apply);
  /// A required positional argument.
  void positional(std::string name, std::string help, std::string* target);
  /// A command line shown under "Examples:" at the end of the help.
  void example(std::string command_line);

  /// Parses args (without the program and command names), applying the options in the order
  /// they were given (a later one overrides an earlier one). Returns false if --help was given
  /// (the help text has then been printed).
  bool parse(const std::vector<std::string>& args);
  std::string help() const;
  /// Whether --name is an option of this parser, and whether it is a flag (takes no value).
  bool has(std::string_view name) const { return find(name) != nullptr; }
  bool is_flag(std::string_view name) const {
    const Option* option = find(name);
    return option != nullptr && static_cast<bool>(option->apply_flag);
  }
  /// The options' names, in the order they were registered.
  std::vector<std::string> names() const;

  struct Option {
    std::string name, metavar, help;
    std::function<void(std::string_view)> apply_value;
    std::function<void()> apply_flag;
    OptionGroup group = OptionGroup::Common;
  };
  struct Positional {
    std::string name, help;
    std::string* target;
  };

 private:
  const Option* find(std::string_view name) const;

  std::string command_, summary_;
  OptionGroup group_ = OptionGroup::Common;
  std::vector<Option> options_;
  std::vector<Positional> positionals_;
  std::vector<std::string> examples_;
};

}  // namespace pointfair::cli
