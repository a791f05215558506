// A container's points a chunk at a time: see container_reader.hpp.
#include "pointfair/tiles/container_reader.hpp"

#include <cmath>

#include <algorithm>

#include "pointfair/tiles/container.hpp"

namespace pointfair::tiles {

namespace fs = std::filesystem;

namespace {

// Rows of original indices read at a time.
constexpr std::uint64_t kScanRows = 1u << 15;

enum class Kind { Position, Attribute, Normal, D1, D2, K1, K2, MeanCurvature, LaplacianNorm, Feature };

}  // namespace

struct ContainerChunkReader::Column {
  h5::Dataset data;
  Kind kind;
  std::size_t attribute = 0;
};

ContainerChunkReader::ContainerChunkReader(const fs::path& file, const ContainerReaderOptions& options)
    : io::PointChunkReader(file), options_(options) {
  file_.emplace(h5::File::open(file, false));
  const h5::File& f = *file_;
  const TileTable tiles = read_tile_table(f);
  n_ = point_count(f);
  offsets_ = tiles.offsets;
  std::string positions_path = layout::positions;
  const bool finished = has_finished_run(f);
  if (options.result_positions && f.exists(layout::run_state)) {
    if (!finished)
      f.fail(layout::run_state, "the smoothing run in this file is unfinished: continue it with --resume "
                                "(or read the input positions)");
    positions_path = f.string_attribute(layout::run, "result_positions");
  }
  const auto add = [&](const std::string& path, Kind kind, std::uint64_t width, std::size_t attribute = 0) {
    h5::Dataset d = f.dataset(path);
    if (d.rows() != n_ || d.width() != width)
      f.fail(path, width == 3 ? "expected an [n, 3] array" : "expected one value per point");
    columns_.push_back(Column{std::move(d), kind, attribute});
  };
  add(positions_path, Kind::Position, 3);
  schema_.position_type = f.has_attribute(layout::positions, "source_type") &&
                                  f.string_attribute(layout::positions, "source_type") == "float32"
                              ? io::ScalarType::Float32
                              : io::ScalarType::Float64;
  read_source_format(f, schema_);
  if (f.exists(layout::attributes)) {
    for (const std::string& name : f.members(layout::attributes)) {
      const std::string path = std::string(layout::attributes) + "/" + name;
      schema_.attributes.push_back({name, h5::to_scalar(f.dataset(path).type()), {}});
      add(path, Kind::Attribute, 1, schema_.attributes.size() - 1);
    }
  }
  if (options.run_attributes) {
    if (!finished) f.fail(layout::run, "no finished smoothing run in this file");
    const std::string a = std::string(layout::run_attributes) + "/";
    if (!f.exists(a + "k1")) f.fail(layout::run_attributes, "the run wrote no attributes");
    add(a + "normal", Kind::Normal, 3);
    add(a + "d1", Kind::D1, 3);
    add(a + "d2", Kind::D2, 3);
    add(a + "k1", Kind::K1, 1);
    add(a + "k2", Kind::K2, 1);
    add(a + "mean_curvature", Kind::MeanCurvature, 1);
    add(a + "laplacian_norm", Kind::LaplacianNorm, 1);
    add(a + "feature_class", Kind::Feature, 1);
    if (f.has_attribute(layout::run_attributes, "degenerate"))
      run_.degenerate = static_cast<std::size_t>(f.int_attribute(layout::run_attributes, "degenerate"));
  }
  // Which tiles ascend in original index; every index must be below n (that each appears
  // once is checked chunk by chunk).
  const std::size_t count = tiles.size();
  sorted_.assign(count, 1);
  cursor_.assign(offsets_.begin(), offsets_.end() - 1);
  const h5::Dataset orig = f.dataset(layout::original_index);
  if (orig.rows() != n_ || orig.width() != 1) f.fail(layout::original_index, "size differs from the positions");
  index_.resize(static_cast<std::size_t>(std::min<std::uint64_t>(kScanRows, std::max<std::uint64_t>(n_, 1))));
  for (std::size_t t = 0; t < count; ++t) {
    bool first = true;
    std::uint64_t previous = 0;
    for (std::uint64_t row = offsets_[t]; row < offsets_[t + 1]; row += kScanRows) {
      const std::uint64_t rows = std::min(kScanRows, offsets_[t + 1] - row);
      orig.read_rows(row, rows, index_.data());
      for (std::uint64_t r = 0; r < rows; ++r) {
        if (index_[r] >= n_) f.fail(layout::original_index, "not a permutation of the rows");
        if (!first && index_[r] <= previous) sorted_[t] = 0;
        first = false;
        previous = index_[r];
      }
    }
  }
}

ContainerChunkReader::~ContainerChunkReader() = default;

std::size_t ContainerChunkReader::chunk_points_for(std::uint64_t budget) const {
  std::uint64_t per_point = 1 + 24;  // filled flag, position
  for (const Column& c : columns_) per_point += c.kind == Kind::Position ? 0 : 8 * c.data.width();
  // The reader's index and column scratch, and a point writer's encoding block (4 MiB for
  // PLY and LAS, 1 MiB of text) besides the chunk.
  const std::uint64_t fixed = kScanRows * (8 + 24) + (std::uint64_t{5} << 20);
  const std::uint64_t usable = budget > 2 * fixed ? budget - fixed : budget / 2;
  return static_cast<std::size_t>(std::max<std::uint64_t>(1024, usable / per_point));
}

void ContainerChunkReader::read_range(std::uint64_t first, std::uint64_t count, std::uint64_t block_begin,
                                      const std::uint64_t* originals, io::PointTable& chunk) {
  const std::uint64_t block_size = chunk.positions.size();
  const auto slot_of = [&](std::uint64_t r, std::uint64_t& slot) {
    const std::uint64_t o = originals ? originals[r] : first + r;
    if (o < block_begin || o >= block_begin + block_size) return false;
    slot = o - block_begin;
    return true;
  };
  for (Column& c : columns_) {
    const std::uint64_t width = c.data.width();
    scratch_.resize(count * width);
    c.data.read_rows(first, count, scratch_.data());
    std::uint64_t slot = 0;
    for (std::uint64_t r = 0; r < count; ++r) {
      if (!slot_of(r, slot)) continue;
      const double* v = scratch_.data() + r * width;
      switch (c.kind) {
        case Kind::Position:
          chunk.positions[slot] = Vec3(v[0], v[1], v[2]);
          filled_[slot] += 1;
          break;
        case Kind::Attribute:
          // The readers' rule (docs/hostile-inputs.md): attribute values are finite.
          if (!std::isfinite(v[0]))
            file_->fail(c.data.path(), "row " + std::to_string(first + r) + " has a non-finite value");
          chunk.attributes[c.attribute].values[slot] = v[0];
          break;
        case Kind::Normal:
          run_.normal[slot] = Vec3(v[0], v[1], v[2]);
          break;
        case Kind::D1:
          run_.d1[slot] = Vec3(v[0], v[1], v[2]);
          break;
        case Kind::D2:
          run_.d2[slot] = Vec3(v[0], v[1], v[2]);
          break;
        case Kind::K1:
          run_.k1[slot] = v[0];
          break;
        case Kind::K2:
          run_.k2[slot] = v[0];
          break;
        case Kind::MeanCurvature:
          run_.mean_curvature[slot] = v[0];
          break;
        case Kind::LaplacianNorm:
          run_.laplacian_norm[slot] = v[0];
          break;
        case Kind::Feature:
          run_.feature[slot] = static_cast<FeatureClass>(static_cast<int>(v[0]));
          break;
      }
    }
  }
}

std::size_t ContainerChunkReader::append(io::PointTable& chunk, std::size_t max_points) {
  const std::uint64_t begin = points_read_;
  const std::uint64_t count = std::min<std::uint64_t>(max_points, n_ - begin);
  if (count == 0) return 0;
  const auto m = static_cast<std::size_t>(count);
  chunk.quantization = schema_.quantization;
  chunk.las = schema_.las;
  chunk.text = schema_.text;
  chunk.ply = schema_.ply;
  chunk.positions.assign(m, Vec3::Zero());
  for (io::Attribute& a : chunk.attributes) a.values.assign(m, 0.0);
  if (options_.run_attributes) {
    run_.normal.assign(m, Vec3::Zero());
    run_.d1.assign(m, Vec3::Zero());
    run_.d2.assign(m, Vec3::Zero());
    for (auto* v : {&run_.k1, &run_.k2, &run_.mean_curvature, &run_.laplacian_norm}) v->assign(m, 0.0);
    run_.feature.assign(m, FeatureClass{});
  }
  filled_.assign(m, 0);
  if (!options_.original_order) {
    for (std::uint64_t first = 0; first < count; first += kScanRows)
      read_range(begin + first, std::min(kScanRows, count - first), begin, nullptr, chunk);
  } else {
    const std::uint64_t end = begin + count;
    const h5::Dataset orig = file_->dataset(layout::original_index);
    for (std::size_t t = 0; t + 1 < offsets_.size(); ++t) {
      const std::uint64_t tile_end = offsets_[t + 1];
      if (sorted_[t]) {
        // Continues where the last chunk stopped, up to the first index past this chunk.
        std::uint64_t row = cursor_[t];
        while (row < tile_end) {
          const std::uint64_t rows = std::min(kScanRows, tile_end - row);
          orig.read_rows(row, rows, index_.data());
          std::uint64_t stop = 0;
          while (stop < rows && index_[stop] < end) ++stop;
          if (stop > 0) read_range(row, stop, begin, index_.data(), chunk);
          row += stop;
          if (stop < rows) break;
        }
        cursor_[t] = row;
        continue;
      }
      for (std::uint64_t row = offsets_[t]; row < tile_end; row += kScanRows) {
        const std::uint64_t rows = std::min(kScanRows, tile_end - row);
        orig.read_rows(row, rows, index_.data());
        std::uint64_t lo = rows, hi = 0;
        for (std::uint64_t r = 0; r < rows; ++r) {
          if (index_[r] < begin || index_[r] >= end) continue;
          lo = std::min(lo, r);
          hi = r + 1;
        }
        if (lo < hi) read_range(row + lo, hi - lo, begin, index_.data() + lo, chunk);
      }
    }
  }
  for (std::size_t i = 0; i < m; ++i)
    if (filled_[i] != 1) file_->fail(layout::original_index, "not a permutation of the rows");
  return m;
}

}  // namespace pointfair::tiles
