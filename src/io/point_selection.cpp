#include "pointfair/io/point_selection.hpp"

#include <cassert>
#include <cmath>
#include <string>

#include "pointfair/io/attribute_roles.hpp"

namespace pointfair::io {

namespace {

// The code 0..255 that `value` holds, or -1 when it is not a whole number in that range.
int code_of(double value) {
  if (!(value >= 0.0 && value <= 255.0) || std::floor(value) != value) return -1;
  return static_cast<int>(value);
}

const Attribute& required(const PointTable& table, const char* name, const std::filesystem::path& file) {
  const Attribute* a = table.find(name);
  if (a == nullptr)
    throw IoError(file.string() + ": has no " + name + " attribute, which selecting points by their returns needs");
  return *a;
}

}  // namespace

std::vector<std::size_t> selected_rows(const PointTable& table, const PointSelection& selection,
                                       const std::filesystem::path& file) {
  std::vector<std::size_t> rows;
  const Attribute* classes = nullptr;
  if (selection.classes.any()) {
    classes = classification_column(table);
    if (classes == nullptr)
      throw IoError(file.string() +
                    ": has no classification ('classification' or 'class' attribute, of a LAS file or a PLY or "
                    "text file with such a column), which selecting points by class needs");
  }
  const Attribute* number = nullptr;
  const Attribute* count = nullptr;
  if (selection.returns == ReturnSelection::First || selection.returns == ReturnSelection::Last ||
      selection.returns == ReturnSelection::Numbers)
    number = &required(table, "return_number", file);
  if (selection.returns == ReturnSelection::Last || selection.returns == ReturnSelection::Only)
    count = &required(table, "number_of_returns", file);
  for (std::size_t i = 0; i < table.size(); ++i) {
    if (classes != nullptr) {
      const int c = code_of(classes->values[i]);
      if (c < 0 || !selection.classes.test(static_cast<std::size_t>(c))) continue;
    }
    bool keep = true;
    switch (selection.returns) {
      case ReturnSelection::Any: break;
      case ReturnSelection::First: keep = number->values[i] == 1.0; break;
      case ReturnSelection::Last: keep = number->values[i] == count->values[i]; break;
      case ReturnSelection::Only: keep = count->values[i] == 1.0; break;
      case ReturnSelection::Numbers: {
        const int r = code_of(number->values[i]);
        keep = r >= 0 && selection.return_numbers.test(static_cast<std::size_t>(r));
        break;
      }
    }
    if (keep) rows.push_back(i);
  }
  return rows;
}

PointTable select_rows(const PointTable& table, std::span<const std::size_t> rows) {
  PointTable part;
  part.position_type = table.position_type;
  part.quantization = table.quantization;
  part.las = table.las;
  part.text = table.text;
  part.ply = table.ply;
  part.positions.reserve(rows.size());
  for (const std::size_t i : rows) part.positions.push_back(table.positions[i]);
  part.attributes.reserve(table.attributes.size());
  for (const Attribute& a : table.attributes) {
    Attribute& b = part.attributes.emplace_back(Attribute{a.name, a.type, {}});
    b.values.reserve(rows.size());
    for (const std::size_t i : rows) b.values.push_back(a.values[i]);
  }
  return part;
}

void splice_rows(PointTable& table, std::span<const std::size_t> rows, const PointTable& part) {
  assert(part.size() == rows.size());
  for (std::size_t j = 0; j < rows.size(); ++j) table.positions[rows[j]] = part.positions[j];
  for (const Attribute& a : part.attributes) {
    Attribute* target = table.find(a.name);
    assert(target != nullptr);
    target->type = a.type;
    for (std::size_t j = 0; j < rows.size(); ++j) target->values[rows[j]] = a.values[j];
  }
}

namespace {

class SelectedReader final : public PointChunkReader {
 public:
  SelectedReader(std::unique_ptr<PointChunkReader> source, const PointSelection& selection)
      : PointChunkReader(source->path()), source_(std::move(source)), selection_(selection) {
    schema_ = source_->schema();
    selected_rows(schema_, selection_, path_);  // a missing field is an error before any read
  }
  std::optional<std::uint64_t> count() const override { return std::nullopt; }

 protected:
  std::size_t append(PointTable& chunk, std::size_t max_points) override {
    std::size_t got = 0;
    while (got < max_points) {
      const std::size_t read = source_->read(scratch_, max_points - got);
      // What the source learns on the way (a LAS file's EVLRs, after its last point).
      schema_.las = source_->schema().las;
      chunk.quantization = scratch_.quantization;
      chunk.las = scratch_.las;
      chunk.text = scratch_.text;
      chunk.ply = scratch_.ply;
      if (read == 0) break;
      const std::vector<std::size_t> rows = selected_rows(scratch_, selection_, path_);
      for (const std::size_t i : rows) chunk.positions.push_back(scratch_.positions[i]);
      for (std::size_t a = 0; a < chunk.attributes.size(); ++a)
        for (const std::size_t i : rows) chunk.attributes[a].values.push_back(scratch_.attributes[a].values[i]);
      got += rows.size();
    }
    return got;
  }

 private:
  std::unique_ptr<PointChunkReader> source_;
  PointSelection selection_;
  PointTable scratch_;
};

}  // namespace

std::unique_ptr<PointChunkReader> open_selected_reader(std::unique_ptr<PointChunkReader> source,
                                                       const PointSelection& selection) {
  return std::make_unique<SelectedReader>(std::move(source), selection);
}

}  // namespace pointfair::io
