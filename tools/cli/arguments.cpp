#include "arguments.hpp"

#include <charconv>
#include <cmath>
#include <iostream>
#include <sstream>

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

ArgumentParser::ArgumentParser(std::string command, std::string summary)
    : command_(std::move(command)), summary_(std::move(summary)) {}

void ArgumentParser::value(std::string name, std::string metavar, std::string help,
                           std::function<void(std::string_view)> apply) {
  options_.push_back({std::move(name), std::move(metavar), std::move(help), std::move(apply), {}});
}

void ArgumentParser::flag(std::string name, std::string help, std::function<void()> apply) {
  options_.push_back({std::move(name), "", std::move(help), {}, std::move(apply)});
}

void ArgumentParser::positional(std::string name, std::string help, std::string* target) {
  positionals_.push_back({std::move(name), std::move(help), target});
}

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
  std::size_t next_positional = 0;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << help();
      return false;
    }
    if (arg.size() > 2 && arg.starts_with("--")) {
      std::string name = arg.substr(2);
      std::string inline_value;
      bool has_inline = false;
      if (const auto eq = name.find('='); eq != std::string::npos) {
        inline_value = name.substr(eq + 1);
        name = name.substr(0, eq);
        has_inline = true;
      }
      const Option* option = find(name);
      if (!option)
        throw UsageError(command_ + ": unknown option '--" + name + "' (see --help)");
      if (option->apply_flag) {
        if (has_inline) throw UsageError(command_ + ": --" + name + " takes no value");
        option->apply_flag();
        continue;
      }
      if (!has_inline) {
        if (i + 1 >= args.size())
          throw UsageError(command_ + ": --" + name + " needs a value " + option->metavar);
        inline_value = args[++i];
      }
      option->apply_value(inline_value);
      continue;
    }
    if (next_positional >= positionals_.size())
      throw UsageError(command_ + ": unexpected argument '" + arg + "' (see --help)");
    *positionals_[next_positional++].target = arg;
  }
  if (next_positional < positionals_.size())
    throw UsageError(command_ + ": missing argument " + positionals_[next_positional].name +
                     " (see --help)");
  return true;
}

std::string ArgumentParser::help() const {
  std::ostringstream out;
  out << "usage: " << command_;
  if (!options_.empty()) out << " [options]";
  for (const auto& p : positionals_) out << ' ' << p.name;
  out << "\n\n" << summary_ << "\n";
  if (!positionals_.empty()) {
    out << "\narguments:\n";
    for (const auto& p : positionals_) out << "  " << p.name << "\n      " << p.help << "\n";
  }
  if (!options_.empty()) {
    out << "\noptions:\n";
    for (const auto& o : options_) {
      out << "  --" << o.name;
      if (!o.metavar.empty()) out << ' ' << o.metavar;
      out << "\n      " << o.help << "\n";
    }
    out << "  --help\n      Show this text.\n";
  }
  return out.str();
}

}  // namespace pointfair::cli
