#pragma once
// The points a run smooths when not all of them should move: LAS classification codes and
// return numbers (airborne scans whose vegetation must stay as it was). Rows of a table are
// picked by these fields, cut out into a table of their own and put back, so that every other
// point is written back as it was read.
#include <bitset>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <vector>

#include "pointfair/io/point_chunks.hpp"
#include "pointfair/io/point_table.hpp"

namespace pointfair::io {

/// Which returns of a pulse a selection keeps (LAS return_number and number_of_returns).
enum class ReturnSelection {
  Any,      ///< every return
  First,    ///< return_number 1
  Last,     ///< return_number == number_of_returns (single returns included)
  Only,     ///< number_of_returns 1
  Numbers,  ///< return_number in PointSelection::return_numbers
};

/// The points to smooth: both conditions hold. The default selects every point.
struct PointSelection {
  /// Classification codes (0..255) to keep; none set: any class (no classification needed).
  std::bitset<256> classes;
  ReturnSelection returns = ReturnSelection::Any;
  /// Return numbers (0..255) to keep with ReturnSelection::Numbers.
  std::bitset<256> return_numbers;

  /// True when it keeps every point of any table (nothing to test).
  bool all() const { return classes.none() && returns == ReturnSelection::Any; }
};

/// Indices (ascending) of the rows of `table` that `selection` keeps. The classification is
/// the attribute classification_column names; the returns are "return_number" and
/// "number_of_returns". A value that is not a whole number in 0..255 matches no code.
/// Throws IoError "<file>: has no classification ..." (or "... no return_number ...") when the
/// selection needs a field the table lacks; `file` names the table's source.
std::vector<std::size_t> selected_rows(const PointTable& table, const PointSelection& selection,
                                       const std::filesystem::path& file);

/// The rows `rows` of `table` as a table of their own: positions and every attribute, with
/// the source's quantization and layouts.
PointTable select_rows(const PointTable& table, std::span<const std::size_t> rows);

/// Writes the positions and attributes of `part` back into rows `rows` of `table`
/// (part.size() == rows.size(); every attribute of `part` must exist in `table` with the same
/// name). Other rows and attributes are left as they are.
void splice_rows(PointTable& table, std::span<const std::size_t> rows, const PointTable& part);

/// A reader that returns only the points of `source` that `selection` keeps, in order, with
/// the source's schema (its LAS records kept up to date with the source's). count() is
/// unknown (nullopt). Throws IoError naming the file when the source lacks a field the
/// selection needs.
std::unique_ptr<PointChunkReader> open_selected_reader(std::unique_ptr<PointChunkReader> source,
                                                       const PointSelection& selection);

}  // namespace pointfair::io
