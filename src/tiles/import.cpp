// Streaming import: count and bounds, a histogram of a fine grid and the tiles built from
// it, then the scatter of every point into its tile's rows through one bounded buffer.
#include "pointfair/tiles/import.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <unordered_map>

#include "pointfair/common/params_error.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/io/point_folder.hpp"
#include "pointfair/tiles/container_reader.hpp"
#include "temporary_file.hpp"

namespace pointfair::tiles {

namespace fs = std::filesystem;

namespace {

constexpr std::uint64_t kMaxHistogramCells = std::uint64_t{1} << 21;
constexpr std::uint64_t kMaxGridCells = std::uint64_t{1} << 22;  // as make_tiling
// The reader's own buffers (PLY block, file buffer), held besides its chunk.
constexpr std::uint64_t kReaderBytes = std::uint64_t{6} << 20;
constexpr std::uint32_t kNoTile = std::numeric_limits<std::uint32_t>::max();
constexpr std::uint32_t kSplitCell = kNoTile - 1;

template <class T>
std::uint64_t bytes(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}

[[noreturn]] void changed(const fs::path& input) {
  throw io::IoError(input.string() + ": the file changed while it was being imported");
}

// A grid over the cloud's bounds: cell (x, y, z) has index x + dims[0] * (y + dims[1] * z).
struct Grid {
  Box bounds{};
  std::array<std::uint64_t, 3> dims{1, 1, 1};
  std::array<double, 3> scale{0, 0, 0};  // cells per length unit
  bool fixed_size = false;               // cells of edge 1 / scale (a tile grid)

  std::uint64_t cells() const { return dims[0] * dims[1] * dims[2]; }
  std::array<std::uint64_t, 3> coords(const Vec3& p) const {
    std::array<std::uint64_t, 3> g{0, 0, 0};
    for (std::size_t c = 0; c < 3; ++c) {
      const double f = std::floor((p[static_cast<Eigen::Index>(c)] - bounds[c]) * scale[c]);
      g[c] = std::min<std::uint64_t>(dims[c] - 1, static_cast<std::uint64_t>(std::max(0.0, f)));
    }
    return g;
  }
  std::uint64_t cell_of(const Vec3& p) const {
    const auto g = coords(p);
    return g[0] + dims[0] * (g[1] + dims[1] * g[2]);
  }
};

// Up to `max_cells` cells, about cubic, over the bounds (an axis of zero extent gets one).
Grid histogram_grid(const Box& b, std::uint64_t max_cells) {
  Grid g;
  g.bounds = b;
  double extent[3];
  double volume = 1.0;
  int axes = 0;
  for (std::size_t c = 0; c < 3; ++c) {
    extent[c] = b[c + 3] - b[c];
    if (extent[c] > 0.0) {
      volume *= extent[c];
      ++axes;
    }
  }
  if (axes == 0) return g;
  const double side = std::pow(volume / static_cast<double>(max_cells), 1.0 / axes);
  for (std::size_t c = 0; c < 3; ++c) {
    if (!(extent[c] > 0.0)) continue;
    const double cells = std::floor(extent[c] / side);
    g.dims[c] = static_cast<std::uint64_t>(std::clamp(cells, 1.0, static_cast<double>(max_cells)));
  }
  while (g.cells() > max_cells) {
    const auto largest = static_cast<std::size_t>(std::max_element(g.dims.begin(), g.dims.end()) - g.dims.begin());
    g.dims[largest] = std::max<std::uint64_t>(1, g.dims[largest] - std::max<std::uint64_t>(1, g.dims[largest] / 16));
  }
  for (std::size_t c = 0; c < 3; ++c)
    g.scale[c] = extent[c] > 0.0 ? static_cast<double>(g.dims[c]) / extent[c] : 0.0;
  return g;
}

// The tile grid of make_tiling: cubic cells of edge `cell_size` from the bounds' minimum.
Grid tile_grid(const Box& b, double cell_size, std::uint64_t points) {
  Grid g;
  g.bounds = b;
  g.fixed_size = true;
  if (points > 0) {
    for (std::size_t c = 0; c < 3; ++c) {
      const double cells = std::floor((b[c + 3] - b[c]) / cell_size) + 1.0;
      require(cells <= double(1u << 22), "tile grid too fine: increase the cell size");
      g.dims[c] = static_cast<std::uint64_t>(cells);
      g.scale[c] = 1.0 / cell_size;
    }
  }
  require(g.cells() <= kMaxGridCells, "tile grid has " + std::to_string(g.cells()) +
                                          " cells (at most 4194304): increase the cell size");
  return g;
}

// Counts of boxes of cells in O(1): a summed-volume table with one row of zeros in front of
// every axis.
class BoxCounts {
 public:
  BoxCounts(const Grid& g, std::vector<std::uint64_t>&& counts) : d_(g.dims) {
    const std::uint64_t sx = d_[0] + 1, sy = d_[1] + 1, sz = d_[2] + 1;
    sum_.assign(sx * sy * sz, 0);
    for (std::uint64_t z = 0; z < d_[2]; ++z)
      for (std::uint64_t y = 0; y < d_[1]; ++y)
        for (std::uint64_t x = 0; x < d_[0]; ++x)
          sum_[at(x + 1, y + 1, z + 1)] = counts[x + d_[0] * (y + d_[1] * z)];
    counts = std::vector<std::uint64_t>();
    for (std::uint64_t z = 1; z < sz; ++z)
      for (std::uint64_t y = 1; y < sy; ++y)
        for (std::uint64_t x = 1; x < sx; ++x) sum_[at(x, y, z)] += sum_[at(x - 1, y, z)];
    for (std::uint64_t z = 1; z < sz; ++z)
      for (std::uint64_t y = 1; y < sy; ++y)
        for (std::uint64_t x = 1; x < sx; ++x) sum_[at(x, y, z)] += sum_[at(x, y - 1, z)];
    for (std::uint64_t z = 1; z < sz; ++z)
      for (std::uint64_t y = 1; y < sy; ++y)
        for (std::uint64_t x = 1; x < sx; ++x) sum_[at(x, y, z)] += sum_[at(x, y, z - 1)];
  }
  // Points in cells [lo, hi) (per axis).
  std::uint64_t count(const std::array<std::uint64_t, 3>& lo, const std::array<std::uint64_t, 3>& hi) const {
    const auto s = [&](std::uint64_t x, std::uint64_t y, std::uint64_t z) { return sum_[at(x, y, z)]; };
    // Inclusion-exclusion, ordered so that no intermediate goes below zero.
    return s(hi[0], hi[1], hi[2]) + s(lo[0], lo[1], hi[2]) + s(lo[0], hi[1], lo[2]) + s(hi[0], lo[1], lo[2]) -
           s(lo[0], hi[1], hi[2]) - s(hi[0], lo[1], hi[2]) - s(hi[0], hi[1], lo[2]) - s(lo[0], lo[1], lo[2]);
  }
  std::uint64_t bytes() const { return tiles::bytes(sum_); }

 private:
  std::uint64_t at(std::uint64_t x, std::uint64_t y, std::uint64_t z) const {
    return x + (d_[0] + 1) * (y + (d_[1] + 1) * z);
  }
  std::array<std::uint64_t, 3> d_;
  std::vector<std::uint64_t> sum_;
};

// A histogram cell cut into tiles of `per` consecutive input points.
struct SplitCell {
  std::uint32_t first_tile = 0;
  std::uint64_t per = 0;
  std::uint64_t seen = 0;
};

// Tiles as boxes of histogram cells, built by kd splitting of the counts.
class TileBuilder {
 public:
  TileBuilder(const Grid& g, const BoxCounts& counts, std::uint64_t max_points, std::vector<std::uint32_t>& tile_of_cell,
              std::vector<std::uint64_t>& tile_counts, std::unordered_map<std::uint64_t, SplitCell>& splits)
      : g_(g), counts_(counts), max_(max_points), tile_of_cell_(tile_of_cell), tile_counts_(tile_counts), splits_(splits) {}

  // Tiles cut from over-full cells.
  std::size_t split_tiles = 0;

  void build(std::array<std::uint64_t, 3> lo, std::array<std::uint64_t, 3> hi, std::uint64_t total) {
    if (total == 0) return;
    tighten(lo, hi, total);
    if (total <= max_) {
      leaf(lo, hi, total);
      return;
    }
    std::size_t axis = 3;
    double longest = -1.0;
    for (std::size_t c = 0; c < 3; ++c) {
      if (hi[c] - lo[c] < 2) continue;
      const double length = static_cast<double>(hi[c] - lo[c]) / (g_.scale[c] > 0 ? g_.scale[c] : 1.0);
      if (length > longest) {
        longest = length;
        axis = c;
      }
    }
    if (axis == 3) {
      split_cell(lo, total);
      return;
    }
    // The first plane with at least half of the points below it, inside (lo, hi): both sides
    // hold points because the box is tight.
    std::uint64_t a = lo[axis] + 1, b = hi[axis] - 1;
    while (a < b) {
      const std::uint64_t mid = a + (b - a) / 2;
      auto upper = hi;
      upper[axis] = mid;
      if (2 * counts_.count(lo, upper) >= total) {
        b = mid;
      } else {
        a = mid + 1;
      }
    }
    auto left_hi = hi, right_lo = lo;
    left_hi[axis] = a;
    right_lo[axis] = a;
    const std::uint64_t left = counts_.count(lo, left_hi);
    build(lo, left_hi, left);
    build(right_lo, hi, total - left);
  }

 private:
  // Shrinks the box to the cells that hold its points.
  void tighten(std::array<std::uint64_t, 3>& lo, std::array<std::uint64_t, 3>& hi, std::uint64_t total) const {
    for (std::size_t c = 0; c < 3; ++c) {
      // Smallest s with points in [lo, s + 1).
      std::uint64_t a = lo[c], b = hi[c] - 1;
      while (a < b) {
        const std::uint64_t mid = a + (b - a) / 2;
        auto upper = hi;
        upper[c] = mid + 1;
        if (counts_.count(lo, upper) > 0) {
          b = mid;
        } else {
          a = mid + 1;
        }
      }
      lo[c] = a;
      // Smallest s with every point in [lo, s).
      a = lo[c] + 1;
      b = hi[c];
      while (a < b) {
        const std::uint64_t mid = a + (b - a) / 2;
        auto upper = hi;
        upper[c] = mid;
        if (counts_.count(lo, upper) == total) {
          b = mid;
        } else {
          a = mid + 1;
        }
      }
      hi[c] = a;
    }
  }

  std::uint32_t new_tile(std::uint64_t count) {
    if (tile_counts_.size() >= kSplitCell) throw ParamError("too many tiles: raise the tile size");
    tile_counts_.push_back(count);
    return static_cast<std::uint32_t>(tile_counts_.size() - 1);
  }

  void leaf(const std::array<std::uint64_t, 3>& lo, const std::array<std::uint64_t, 3>& hi, std::uint64_t total) {
    const std::uint32_t t = new_tile(total);
    for (std::uint64_t z = lo[2]; z < hi[2]; ++z)
      for (std::uint64_t y = lo[1]; y < hi[1]; ++y)
        for (std::uint64_t x = lo[0]; x < hi[0]; ++x) tile_of_cell_[x + g_.dims[0] * (y + g_.dims[1] * z)] = t;
  }

  void split_cell(const std::array<std::uint64_t, 3>& cell, std::uint64_t total) {
    const std::uint64_t pieces = (total + max_ - 1) / max_;
    const std::uint64_t per = (total + pieces - 1) / pieces;
    SplitCell s;
    s.per = per;
    for (std::uint64_t done = 0; done < total; done += per) {
      const std::uint32_t t = new_tile(std::min(per, total - done));
      if (done == 0) s.first_tile = t;
      ++split_tiles;
    }
    const std::uint64_t index = cell[0] + g_.dims[0] * (cell[1] + g_.dims[1] * cell[2]);
    tile_of_cell_[index] = kSplitCell;
    splits_[index] = s;
  }

  const Grid& g_;
  const BoxCounts& counts_;
  std::uint64_t max_;
  std::vector<std::uint32_t>& tile_of_cell_;
  std::vector<std::uint64_t>& tile_counts_;
  std::unordered_map<std::uint64_t, SplitCell>& splits_;
};

class Import {
 public:
  Import(const fs::path& input, const fs::path& output, const StreamImportOptions& options)
      : input_(input), output_(output), options_(options), tiling_(options.container.tiling),
        ranks_(options.ranks != nullptr ? options.ranks : &single_) {}

  StreamImportReport run();

 private:
  void progress(const char* pass, std::uint64_t done, std::uint64_t total) const {
    if (options_.progress) options_.progress(pass, done, total);
  }
  void account(std::uint64_t working) {
    const std::uint64_t total = persistent_ + working;
    report_.peak_accounted_bytes = std::max(report_.peak_accounted_bytes, total);
    if (total > options_.memory_budget)
      throw ParamError("the memory budget of " + std::to_string(options_.memory_budget >> 20) +
                       " MiB is too small to import " + input_.string() + " (it needs " +
                       std::to_string((total >> 20) + 1) + " MiB here): raise --memory-budget");
  }
  std::uint64_t chunk_bytes(const io::PointTable& chunk) const {
    std::uint64_t b = bytes(chunk.positions);
    for (const auto& a : chunk.attributes) b += bytes(a.values);
    return b + kReaderBytes;
  }
  std::unique_ptr<io::PointChunkReader> open_share(const io::ReadOptions& read) const;
  std::size_t read_share(io::PointChunkReader& reader, io::PointTable& chunk) const;
  void count_and_bounds();
  void build_tiles();
  void place_share();
  void write_file(const fs::path& temp);
  void scatter(h5::File& file);
  void flush(h5::File& file);
  void write_metadata(h5::File& file) const;
  void create_point_datasets(h5::File& file, const h5::DatasetOptions& options) const;
  void copy_compressed(const h5::File& staging, h5::File& file) const;

  fs::path input_, output_;
  StreamImportOptions options_;
  TilingParams tiling_;
  Ranks single_;
  Ranks* ranks_;
  // This rank's share of the input: points [first_, end_) in input order.
  std::uint64_t first_ = 0, end_ = std::numeric_limits<std::uint64_t>::max();
  // Per histogram cell, this rank's points (several ranks only, until place_share).
  std::vector<std::uint64_t> local_cells_;
  // Per tile, this rank's points and those of the ranks below it (several ranks only).
  std::vector<std::uint64_t> mine_, below_;
  StreamImportReport report_;
  std::uint64_t persistent_ = 0;

  io::PointTable schema_;
  std::size_t read_chunk_ = 1;  // points per chunk read
  std::uint64_t n_ = 0;
  Box bounds_{};
  Grid grid_;
  std::vector<std::uint32_t> tile_of_cell_;  // histogram grids only
  std::unordered_map<std::uint64_t, SplitCell> splits_;
  std::vector<std::uint64_t> tile_counts_, offsets_, filled_;
  std::vector<Box> tile_bounds_;

  // The scatter buffer: one entry per buffered point, in input order.
  std::uint64_t capacity_ = 0;
  std::vector<std::uint32_t> buffer_tile_;
  std::vector<std::uint64_t> buffer_index_;
  std::vector<double> buffer_xyz_;
  std::vector<double> buffer_values_;  // attribute-major: attribute a of entry i at a * capacity_ + i
  std::vector<std::uint32_t> order_;
  std::vector<double> scratch_;
  std::vector<std::uint64_t> scratch_index_;
  std::vector<std::uint32_t> run_start_;  // per tile, during a flush
};

namespace {

// A point file, a folder of them (their positions, as one cloud: io::open_folder_reader), or a
// container (its input positions and attributes in its points' original order): a container
// imported again gets the tiles of another budget.
// With a selection, only the points it keeps.
std::unique_ptr<io::PointChunkReader> open_input(const std::filesystem::path& input, const io::PointSelection& select,
                                                 const io::ReadOptions& read = {}) {
  std::string e = input.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  std::unique_ptr<io::PointChunkReader> reader;
  if (e == ".h5" || e == ".hdf5") reader = std::make_unique<ContainerChunkReader>(input, ContainerReaderOptions{.result_positions = false});
  else if (fs::is_directory(input)) reader = io::open_folder_reader(io::point_files_in(input), read);
  else reader = io::open_point_reader(input, read);
  if (select.all()) return reader;
  return io::open_selected_reader(std::move(reader), select);
}

}  // namespace

std::unique_ptr<io::PointChunkReader> Import::open_share(const io::ReadOptions& read) const {
  auto reader = open_input(input_, options_.select, read);
  if (first_ > 0 && reader->skip(first_) != first_) changed(input_);
  return reader;
}

// The next chunk of this rank's share (0 at its end).
std::size_t Import::read_share(io::PointChunkReader& reader, io::PointTable& chunk) const {
  const std::uint64_t at = reader.points_read();
  if (at >= end_) return 0;
  return reader.read(chunk, static_cast<std::size_t>(std::min<std::uint64_t>(read_chunk_, end_ - at)));
}

void Import::count_and_bounds() {
  constexpr double inf = std::numeric_limits<double>::infinity();
  bounds_ = {inf, inf, inf, -inf, -inf, -inf};
  // Without a declared count (text), rank 0 reads everything and the others nothing.
  std::optional<std::uint64_t> declared;
  {
    const auto probe = open_input(input_, options_.select);  // warnings come from the share's reader
    schema_ = probe->schema();
    declared = probe->count();
  }
  const auto size = static_cast<std::uint64_t>(ranks_->size()), rank = static_cast<std::uint64_t>(ranks_->rank());
  if (size > 1) {
    first_ = declared ? *declared * rank / size : 0;
    end_ = declared ? *declared * (rank + 1) / size : rank == 0 ? end_ : 0;
  }
  const auto reader = open_share(options_.read);
  for (const auto& a : schema_.attributes) {
    if (a.name.empty() || a.name.find('/') != std::string::npos || a.name == ".")
      throw io::IoError(output_.string() + ": attribute name '" + a.name + "' cannot name an HDF5 dataset");
  }
  // The chunk within an eighth of the budget, however many attributes a point has.
  const std::uint64_t point_bytes = 24 + 8 * schema_.attributes.size();
  read_chunk_ = static_cast<std::size_t>(std::clamp<std::uint64_t>(
      options_.memory_budget / 8 / point_bytes, 1, options_.read_chunk_points));
  io::PointTable chunk;
  while (const std::size_t got = read_share(*reader, chunk)) {
    account(chunk_bytes(chunk));
    for (std::size_t i = 0; i < got; ++i)
      for (std::size_t c = 0; c < 3; ++c) {
        const double v = chunk.positions[i][static_cast<Eigen::Index>(c)];
        bounds_[c] = std::min(bounds_[c], v);
        bounds_[c + 3] = std::max(bounds_[c + 3], v);
      }
    n_ += got;
    progress("count", n_, 0);
  }
  if (size > 1) {
    if (end_ != std::numeric_limits<std::uint64_t>::max() && n_ != end_ - first_) changed(input_);
    // Every rank's reader reads the file's last point (seeking to it), as a single process's
    // does: what a reader learns there (a LAS file's EVLRs) is then the same on every rank.
    if (declared) reader->skip(*declared - reader->points_read());
    // Exact: the maximum over the ranks of (-min, max).
    std::array<double, 6> extent = {-bounds_[0], -bounds_[1], -bounds_[2], bounds_[3], bounds_[4], bounds_[5]};
    ranks_->max(extent);
    bounds_ = {-extent[0], -extent[1], -extent[2], extent[3], extent[4], extent[5]};
    n_ = ranks_->sum(n_);
    if (declared && n_ != *declared) changed(input_);
  }
  // A LAS reader adds the EVLRs (after the points) to its schema once the last point is read:
  // taken only now, after every rank's reader has read it (taken before, only the last rank's
  // share reached them, and the ranks wrote different LAS records).
  schema_.las = reader->schema().las;
  if (n_ >= std::numeric_limits<std::uint32_t>::max())
    throw io::IoError(input_.string() + ": " + std::to_string(n_) + " points exceed the limit of 2^32-2 of a container");
}

void Import::build_tiles() {
  const bool fixed = tiling_.cell_size > 0.0;
  if (n_ == 0) {
    tile_counts_.assign(1, 0);  // one empty tile, as make_tiling
    return;
  }
  if (fixed) {
    grid_ = tile_grid(bounds_, tiling_.cell_size, n_);
  } else {
    // The histogram (and its summed table) within an eighth of the budget.
    const std::uint64_t cells = std::clamp<std::uint64_t>(options_.memory_budget / 8 / 24, 4096, kMaxHistogramCells);
    grid_ = histogram_grid(bounds_, cells);
  }
  std::vector<std::uint64_t> counts(grid_.cells(), 0);
  persistent_ += bytes(counts);
  std::uint64_t seen = 0;
  {
    const auto reader = open_share({});
    io::PointTable chunk;
    while (const std::size_t got = read_share(*reader, chunk)) {
      account(chunk_bytes(chunk));
      for (std::size_t i = 0; i < got; ++i) ++counts[grid_.cell_of(chunk.positions[i])];
      seen += got;
      progress("histogram", seen, n_);
    }
  }
  if (ranks_->size() > 1) {
    // Each rank's own counts place its points in their tiles (place_share); the tiles are
    // built from the sum, the same on every rank.
    local_cells_ = counts;
    persistent_ += bytes(local_cells_);
    account(0);
    ranks_->sum(counts);
    seen = ranks_->sum(seen);
  }
  if (seen != n_) changed(input_);
  report_.histogram_cells = grid_.cells();
  if (fixed) {
    tile_counts_ = std::move(counts);
    persistent_ = bytes(tile_counts_) + bytes(local_cells_);
    return;
  }
  // The counts and their summed table are both held while the table is built.
  account((grid_.dims[0] + 1) * (grid_.dims[1] + 1) * (grid_.dims[2] + 1) * sizeof(std::uint64_t));
  const BoxCounts box_counts(grid_, std::move(counts));
  persistent_ = box_counts.bytes();
  tile_of_cell_.assign(grid_.cells(), kNoTile);
  account(bytes(tile_of_cell_));
  TileBuilder builder(grid_, box_counts, tiling_.max_tile_points, tile_of_cell_, tile_counts_, splits_);
  builder.build({0, 0, 0}, grid_.dims, n_);
  report_.split_cell_tiles = builder.split_tiles;
  persistent_ = bytes(tile_of_cell_) + bytes(local_cells_);  // the summed table is released below
}

void Import::place_share() {
  // Rows of a tile follow the input order and the ranks' shares are consecutive ranges of
  // it: a rank's points of tile t go after those of the ranks below it.
  const std::size_t tiles = tile_counts_.size();
  mine_.assign(tiles, 0);
  if (grid_.fixed_size) {
    std::copy(local_cells_.begin(), local_cells_.end(), mine_.begin());
  } else if (n_ > 0) {
    for (std::uint64_t c = 0; c < local_cells_.size(); ++c) {
      const std::uint32_t t = tile_of_cell_[c];
      if (t != kNoTile && t != kSplitCell) mine_[t] += local_cells_[c];
    }
    // A cell cut into tiles of `per` consecutive input points: this rank's points of it are
    // the cell's [before, before + mine) in input order.
    std::vector<std::uint64_t> cells;
    for (const auto& entry : splits_) cells.push_back(entry.first);
    std::sort(cells.begin(), cells.end());
    std::vector<std::uint64_t> before(cells.size());
    for (std::size_t i = 0; i < cells.size(); ++i) before[i] = local_cells_[cells[i]];
    ranks_->sum_below(before);
    for (std::size_t i = 0; i < cells.size(); ++i) {
      SplitCell& split = splits_.at(cells[i]);
      split.seen = before[i];
      const std::uint64_t end = before[i] + local_cells_[cells[i]];
      for (std::uint64_t p = before[i]; p < end;) {
        const std::uint64_t piece = p / split.per, next = std::min(end, (piece + 1) * split.per);
        mine_[split.first_tile + piece] += next - p;
        p = next;
      }
    }
  }
  persistent_ -= bytes(local_cells_);
  local_cells_ = std::vector<std::uint64_t>();
  below_ = mine_;
  ranks_->sum_below(below_);
  persistent_ += bytes(mine_) + bytes(below_);
}

void Import::write_metadata(h5::File& f) const {
  f.set_attribute("/", "pointfair_format", layout::format_name);
  f.set_attribute("/", "format_version", layout::format_version);
  f.set_attribute("/", "tool_version", version());
  f.set_attribute("/", "source_name", options_.container.source_name);
  f.set_attribute("/", "source_size_bytes", static_cast<std::int64_t>(options_.container.source_size));
  if (!options_.container.source_digest.empty())
    f.set_attribute("/", "source_digest", options_.container.source_digest);
  f.set_attribute("/", "point_count", static_cast<std::int64_t>(n_));
  f.set_attribute("/", "tile_count", static_cast<std::int64_t>(tile_counts_.size()));
}

void Import::create_point_datasets(h5::File& f, const h5::DatasetOptions& dopt) const {
  f.create_group(layout::points);
  f.create_dataset(layout::positions, h5::Type::Float64, n_, 3, dopt);
  f.set_attribute(layout::positions, "source_type",
                  schema_.position_type == io::ScalarType::Float32 ? "float32" : "float64");
  write_source_format(f, schema_);
  f.create_dataset(layout::original_index, h5::Type::UInt64, n_, 0, dopt);
  f.create_group(layout::attributes);
  for (const auto& a : schema_.attributes)
    f.create_dataset(std::string(layout::attributes) + "/" + a.name, h5::to_h5(a.type), n_, 0, dopt);
}

void Import::flush(h5::File& f) {
  const std::uint64_t count = buffer_tile_.size();
  if (count == 0) return;
  ++report_.flushes;
  // A stable counting sort by tile: within a tile, entries keep the input order.
  const std::size_t tiles = tile_counts_.size();
  std::fill(run_start_.begin(), run_start_.end(), 0u);
  for (const std::uint32_t t : buffer_tile_) ++run_start_[t + 1];
  for (std::size_t t = 0; t < tiles; ++t) run_start_[t + 1] += run_start_[t];
  order_.resize(count);
  // Each entry's place in the sorted order, through a running cursor per tile.
  scratch_index_.assign(run_start_.begin(), run_start_.end() - 1);
  for (std::uint64_t i = 0; i < count; ++i) order_[scratch_index_[buffer_tile_[i]]++] = static_cast<std::uint32_t>(i);

  const auto write_runs = [&](h5::Dataset& d, const auto* sorted, std::uint64_t width) {
    for (std::size_t t = 0; t < tiles; ++t) {
      const std::uint32_t begin = run_start_[t], end = run_start_[t + 1];
      if (begin == end) continue;
      d.write_rows(offsets_[t] + filled_[t], end - begin, sorted + std::uint64_t{begin} * width);
    }
  };
  {
    h5::Dataset d = f.dataset(layout::positions);
    scratch_.resize(3 * count);
    for (std::uint64_t r = 0; r < count; ++r)
      for (std::uint64_t c = 0; c < 3; ++c) scratch_[3 * r + c] = buffer_xyz_[3 * std::uint64_t{order_[r]} + c];
    write_runs(d, scratch_.data(), 3);
  }
  {
    h5::Dataset d = f.dataset(layout::original_index);
    scratch_index_.resize(count);
    for (std::uint64_t r = 0; r < count; ++r) scratch_index_[r] = buffer_index_[order_[r]];
    write_runs(d, scratch_index_.data(), 1);
  }
  for (std::size_t a = 0; a < schema_.attributes.size(); ++a) {
    h5::Dataset d = f.dataset(std::string(layout::attributes) + "/" + schema_.attributes[a].name);
    const double* values = buffer_values_.data() + a * capacity_;
    for (std::uint64_t r = 0; r < count; ++r) scratch_[r] = values[order_[r]];
    write_runs(d, scratch_.data(), 1);
  }
  for (std::size_t t = 0; t < tiles; ++t) filled_[t] += run_start_[t + 1] - run_start_[t];
  buffer_tile_.clear();
  buffer_index_.clear();
  buffer_xyz_.clear();
}

void Import::scatter(h5::File& f) {
  const std::size_t tiles = tile_counts_.size();
  const std::size_t k = schema_.attributes.size();
  offsets_.assign(tiles + 1, 0);
  for (std::size_t t = 0; t < tiles; ++t) offsets_[t + 1] = offsets_[t] + tile_counts_[t];
  filled_.assign(tiles, 0);
  if (!below_.empty()) filled_ = below_;
  constexpr double inf = std::numeric_limits<double>::infinity();
  tile_bounds_.assign(tiles, Box{inf, inf, inf, -inf, -inf, -inf});
  run_start_.assign(tiles + 1, 0);
  persistent_ += bytes(tile_counts_) + bytes(offsets_) + bytes(filled_) + bytes(tile_bounds_) + bytes(run_start_) +
                 tiles * sizeof(std::uint64_t) /* the flush's running cursors */;
  // Per buffered point: tile, index, position, attributes; during a flush its place in the
  // sorted order and one sorted column (positions: three values; indices).
  const std::uint64_t per_point = 4 + 8 + 24 + 8 * k + 4 + 24 + 8;
  io::PointTable chunk = schema_;
  const std::uint64_t chunk_estimate = read_chunk_ * (24 + 8 * k) + kReaderBytes;
  const std::uint64_t fixed = persistent_ + chunk_estimate;
  if (fixed + 1024 * per_point > options_.memory_budget)
    throw ParamError("the memory budget of " + std::to_string(options_.memory_budget >> 20) +
                     " MiB is too small to import " + input_.string() + ": raise --memory-budget");
  capacity_ = std::min<std::uint64_t>(std::max<std::uint64_t>(n_, 1), (options_.memory_budget - fixed) / per_point);
  capacity_ = std::min<std::uint64_t>(capacity_, std::numeric_limits<std::uint32_t>::max() - 1);
  buffer_tile_.reserve(capacity_);
  buffer_index_.reserve(capacity_);
  buffer_xyz_.reserve(3 * capacity_);
  buffer_values_.assign(k * capacity_, 0.0);
  order_.reserve(capacity_);
  scratch_.reserve(3 * capacity_);
  // The running cursors (tiles) then the sorted indices (capacity) share scratch_index_.
  persistent_ -= tiles * sizeof(std::uint64_t);
  scratch_index_.reserve(std::max<std::uint64_t>(capacity_, tiles));
  persistent_ += bytes(buffer_tile_) + bytes(buffer_index_) + bytes(buffer_xyz_) + bytes(buffer_values_) +
                 bytes(order_) + bytes(scratch_) + bytes(scratch_index_);

  const auto reader = open_share({});
  std::uint64_t index = first_;
  while (const std::size_t got = read_share(*reader, chunk)) {
    account(chunk_bytes(chunk));
    for (std::size_t i = 0; i < got; ++i, ++index) {
      if (index >= n_) changed(input_);
      const Vec3& p = chunk.positions[i];
      std::uint32_t t = 0;
      if (n_ > 0) {
        const std::uint64_t cell = grid_.cell_of(p);
        if (grid_.fixed_size) {
          t = static_cast<std::uint32_t>(cell);
        } else {
          t = tile_of_cell_[cell];
          if (t == kSplitCell) {
            SplitCell& split = splits_.at(cell);
            t = static_cast<std::uint32_t>(split.first_tile + split.seen / split.per);
            ++split.seen;
          }
          if (t == kNoTile) changed(input_);
        }
      }
      Box& b = tile_bounds_[t];
      for (std::size_t c = 0; c < 3; ++c) {
        b[c] = std::min(b[c], p[static_cast<Eigen::Index>(c)]);
        b[c + 3] = std::max(b[c + 3], p[static_cast<Eigen::Index>(c)]);
      }
      const std::uint64_t slot = buffer_tile_.size();
      buffer_tile_.push_back(t);
      buffer_index_.push_back(index);
      buffer_xyz_.insert(buffer_xyz_.end(), {p.x(), p.y(), p.z()});
      for (std::size_t a = 0; a < k; ++a) buffer_values_[a * capacity_ + slot] = chunk.attributes[a].values[i];
      if (buffer_tile_.size() == capacity_) flush(f);
    }
    progress("scatter", index, n_);
  }
  flush(f);
  if (ranks_->size() > 1) {
    if (index != (end_ == std::numeric_limits<std::uint64_t>::max() ? n_ : end_)) changed(input_);
    for (std::size_t t = 0; t < tiles; ++t)
      if (filled_[t] != below_[t] + mine_[t]) changed(input_);
    // Every tile's bounds: the maximum over the ranks of (-min, max), exact.
    std::vector<double> extent(6 * tiles);
    for (std::size_t t = 0; t < tiles; ++t)
      for (std::size_t c = 0; c < 3; ++c) {
        extent[6 * t + c] = -tile_bounds_[t][c];
        extent[6 * t + c + 3] = tile_bounds_[t][c + 3];
      }
    ranks_->max(extent);
    for (std::size_t t = 0; t < tiles; ++t)
      for (std::size_t c = 0; c < 3; ++c) {
        tile_bounds_[t][c] = -extent[6 * t + c];
        tile_bounds_[t][c + 3] = extent[6 * t + c + 3];
      }
    return;
  }
  if (index != n_) changed(input_);
  for (std::size_t t = 0; t < tiles; ++t)
    if (filled_[t] != tile_counts_[t]) changed(input_);
}

void Import::copy_compressed(const h5::File& staging, h5::File& f) const {
  std::vector<std::string> paths = {layout::positions, layout::original_index};
  for (const auto& a : schema_.attributes) paths.push_back(std::string(layout::attributes) + "/" + a.name);
  const std::uint64_t chunk_rows = std::min<std::uint64_t>(options_.container.chunk_rows, std::max<std::uint64_t>(n_, 1));
  // Whole chunks at a time, so that every compressed chunk is written once.
  const std::uint64_t block = chunk_rows * std::max<std::uint64_t>(1, (std::uint64_t{1} << 18) / chunk_rows);
  std::vector<double> values;
  std::vector<std::uint64_t> indices;
  for (const std::string& path : paths) {
    const h5::Dataset from = staging.dataset(path);
    h5::Dataset to = f.dataset(path);
    for (std::uint64_t first = 0; first < n_; first += block) {
      const std::uint64_t count = std::min(block, n_ - first);
      if (path == layout::original_index) {
        indices.resize(count);
        from.read_rows(first, count, indices.data());
        to.write_rows(first, count, indices.data());
      } else {
        values.resize(count * from.width());
        from.read_rows(first, count, values.data());
        to.write_rows(first, count, values.data());
      }
    }
  }
}

// The tile table, after the points: on every rank (metadata is collective in parallel
// HDF5), its rows written by rank 0.
void write_tile_table(h5::File& f, const TilingParams& tiling, const std::vector<std::uint64_t>& offsets,
                      const std::vector<Box>& bounds, bool writer) {
  f.create_group(layout::tiles);
  f.set_attribute(layout::tiles, "scheme", tiling.cell_size > 0 ? "grid" : "histogram-kd");
  f.set_attribute(layout::tiles, "max_tile_points", static_cast<std::int64_t>(tiling.max_tile_points));
  f.set_attribute(layout::tiles, "cell_size", tiling.cell_size);
  f.set_attribute(layout::tiles, "row_order", "original_index");
  h5::Dataset off = f.create_dataset(layout::tile_offsets, h5::Type::UInt64, offsets.size(), 0);
  h5::Dataset bnd = f.create_dataset(layout::tile_bounds, h5::Type::Float64, bounds.size(), 6);
  if (!writer) return;
  off.write_rows(0, offsets.size(), offsets.data());
  bnd.write_rows(0, bounds.size(), bounds.data()->data());
}

void Import::write_file(const fs::path& temp) {
  h5::DatasetOptions dopt;
  dopt.chunk_rows = std::min<std::uint64_t>(options_.container.chunk_rows, std::max<std::uint64_t>(n_, 1));
  const bool first = ranks_->rank() == 0;
  const auto finish_tiles = [&](h5::File& f, bool writer) {
    if (n_ == 0) {
      offsets_.assign(2, 0);
      constexpr double inf = std::numeric_limits<double>::infinity();
      tile_bounds_.assign(1, Box{inf, inf, inf, -inf, -inf, -inf});
    }
    write_tile_table(f, tiling_, offsets_, tile_bounds_, writer);
    f.flush();
    f.close();
  };
  if (options_.container.deflate == 0) {
    h5::File f = ranks_->create_shared(temp);
    write_metadata(f);
    create_point_datasets(f, dopt);
    scatter(f);
    finish_tiles(f, first);
    return;
  }
  // Compressed chunks are written whole: the scatter goes to an uncompressed staging file
  // first (rows arrive tile by tile, in pieces), then is copied chunk by chunk, by rank 0.
  const fs::path staging_path = ranks_->from_first(temporary_name(output_, ".staging-").string());
  RemoveOnExit remove_staging{first ? staging_path : fs::path()};
  {
    h5::File staging = ranks_->create_shared(staging_path);
    create_point_datasets(staging, dopt);
    scatter(staging);
    staging.close();
  }
  if (first) {
    h5::File f = h5::File::create(temp);
    write_metadata(f);
    h5::DatasetOptions compressed = dopt;
    compressed.deflate = options_.container.deflate;
    create_point_datasets(f, compressed);
    copy_compressed(h5::File::open(staging_path, false), f);
    finish_tiles(f, true);
  }
  ranks_->barrier();
}

StreamImportReport Import::run() {
  tiling_.validate();
  require(options_.memory_budget >= kMinImportBudget, "the import's memory budget must be at least 16 MiB");
  require(options_.read_chunk_points >= 1, "read chunk points must be >= 1");
  require(options_.container.chunk_rows >= 1, "chunk rows must be >= 1");
  require(options_.container.deflate >= 0 && options_.container.deflate <= 9, "deflate level must be in 0..9");
  count_and_bounds();
  build_tiles();
  if (ranks_->size() > 1) place_share();

  const bool first = ranks_->rank() == 0;
  const fs::path temp = ranks_->from_first(temporary_name(output_, ".tmp-").string());
  RemoveOnExit remove_temp{first ? temp : fs::path()};
  try {
    write_file(temp);
  } catch (const io::IoError& e) {
    throw naming_target(e, output_);
  }
  if (first) {
    std::error_code ec;
    fs::rename(temp, output_, ec);
    if (ec) throw io::IoError(output_.string() + ": cannot rename the finished file into place: " + ec.message());
    remove_temp.path.clear();
  }
  ranks_->barrier();  // the container is in place when any rank returns
  report_.points = n_;
  report_.attributes = schema_.attributes.size();
  report_.tiles = tile_counts_.size();
  return report_;
}

}  // namespace

StreamImportReport import_points(const fs::path& input, const fs::path& output, const StreamImportOptions& options) {
  io::require_output_path(output);
  return Import(input, output, options).run();
}

}  // namespace pointfair::tiles
