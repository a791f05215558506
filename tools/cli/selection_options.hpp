#pragma once
// --classes and --returns: which points of a LAS (or classified PLY/text) input smooth moves.
#include <bitset>
#include <cstddef>
#include <string>
#include <string_view>

#include "arguments.hpp"
#include "json_writer.hpp"
#include "pointfair/io/point_selection.hpp"

namespace pointfair::cli {

struct SelectionOptions {
  io::PointSelection selection;
  /// The options as given ("2,6", "last"), for the summaries; empty when not given.
  std::string classes, returns;
};

/// Parses a list of whole numbers and ranges in [low, high] ("2,6", "2-6", "1,3-5") into a
/// set; throws UsageError naming `what` for bad syntax, a value out of range, a backward
/// range or an empty list.
std::bitset<256> parse_code_list(std::string_view text, std::string_view what, int low, int high);

/// Registers --classes LIST and --returns WHICH.
void add_selection_options(ArgumentParser& parser, SelectionOptions& options);

/// Throws UsageError when a selection is given together with output options that would add
/// columns to every point (--attributes, --colour-by): the points left out are written back as
/// they were.
void require_selection_compatible(const SelectionOptions& options, bool attributes, bool colour);

/// {"classes": ..., "returns": ..., "selected_points": selected, "moved_points": moved}.
JsonObject selection_json(const SelectionOptions& options, std::size_t selected, std::size_t moved);

}  // namespace pointfair::cli
