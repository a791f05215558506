#pragma once
// A small command-line parser: named options with a unit and a default in their help line,
// flags, and positional arguments. Errors throw UsageError (exit code 2).
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

class ArgumentParser {
 public:
  ArgumentParser(std::string command, std::string summary);

  /// An option taking a value: --name VALUE or --name=VALUE.
  void value(std::string name, std::string metavar, std::string help,
             std::function<void(std::string_view)> apply);
  /// A flag: --name.
  void flag(std::string name, std::string help, std::function<void()> apply);
  /// A required positional argument.
  void positional(std::string name, std::string help, std::string* target);

  /// Parses args (without the program and command names). Returns false if --help was given
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

 private:
  struct Option {
    std::string name, metavar, help;
    std::function<void(std::string_view)> apply_value;
    std::function<void()> apply_flag;
  };
  struct Positional {
    std::string name, help;
    std::string* target;
  };
  const Option* find(std::string_view name) const;

  std::string command_, summary_;
  std::vector<Option> options_;
  std::vector<Positional> positionals_;
};

}  // namespace pointfair::cli
