#include "selection_options.hpp"

#include <charconv>

namespace pointfair::cli {

namespace {

// A whole number in [low, high], or throws.
int parse_code(std::string_view item, std::string_view whole, std::string_view what, int low, int high) {
  int value = 0;
  const char* end = item.data() + item.size();
  const auto [ptr, ec] = std::from_chars(item.data(), end, value);
  if (item.empty() || ec != std::errc() || ptr != end || value < low || value > high)
    throw UsageError(std::string(what) + " expects whole numbers " + std::to_string(low) + "-" + std::to_string(high) +
                     " separated by commas, ranges as " + std::to_string(low + 1) + "-" + std::to_string(low + 3) +
                     ", got '" + std::string(whole) + "'");
  return value;
}

}  // namespace

std::bitset<256> parse_code_list(std::string_view text, std::string_view what, int low, int high) {
  std::bitset<256> codes;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string_view item = text.substr(start, comma - start);
    const std::size_t dash = item.find('-', 1);
    const int first = parse_code(item.substr(0, dash), text, what, low, high);
    const int last = dash == std::string_view::npos ? first : parse_code(item.substr(dash + 1), text, what, low, high);
    if (last < first)
      throw UsageError(std::string(what) + ": the range '" + std::string(item) + "' runs backwards");
    for (int c = first; c <= last; ++c) codes.set(static_cast<std::size_t>(c));
    start = comma + 1;
  }
  return codes;
}

void add_selection_options(ArgumentParser& p, SelectionOptions& o) {
  const OptionGroup before = p.current_group();
  p.group(OptionGroup::Method);
  p.value("classes", "LIST",
          "Smooth only the points of these LAS classification codes (0-255; commas and ranges: "
          "2,6 or 2-6; from a LAS file's classification, or a 'classification' or 'class' "
          "property of a PLY or text file): only they move and only they are neighbours; every "
          "other point is written back as it was read. Default: every point.",
          [&o](std::string_view v) {
            o.selection.classes = parse_code_list(v, "--classes", 0, 255);
            o.classes = std::string(v);
          });
  p.value("returns", "first|last|only|LIST",
          "Smooth only these returns (with --classes: those of them in the classes): first "
          "(return number 1), last (return number = number of returns, single returns included), "
          "only (single returns), or return numbers (0-15; commas and ranges). Default: every "
          "return.",
          [&o](std::string_view v) {
            using io::ReturnSelection;
            if (v == "first") o.selection.returns = ReturnSelection::First;
            else if (v == "last") o.selection.returns = ReturnSelection::Last;
            else if (v == "only") o.selection.returns = ReturnSelection::Only;
            else {
              o.selection.return_numbers = parse_code_list(v, "--returns", 0, 15);
              o.selection.returns = ReturnSelection::Numbers;
            }
            o.returns = std::string(v);
          });
  p.group(before);
}

void require_selection_compatible(const SelectionOptions& o, bool attributes, bool colour) {
  if (o.selection.all()) return;
  const char* option = !o.classes.empty() ? "--classes" : "--returns";
  if (attributes)
    throw UsageError(std::string(option) + " writes the points it leaves out as they were read: it does not combine "
                     "with --attributes, which adds columns to every point");
  if (colour)
    throw UsageError(std::string(option) + " writes the points it leaves out as they were read: it does not combine "
                     "with --colour-by, which colours every point");
}

JsonObject selection_json(const SelectionOptions& o, std::size_t selected, std::size_t moved) {
  JsonObject j;
  j.add("classes", o.classes.empty() ? std::string("all") : o.classes);
  j.add("returns", o.returns.empty() ? std::string("all") : o.returns);
  j.add("selected_points", selected).add("moved_points", moved);
  return j;
}

}  // namespace pointfair::cli
