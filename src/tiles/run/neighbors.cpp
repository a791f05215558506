// The tiles' neighbourhoods (gathered with their halos, built, rebuilt) and the lambda sample.
#include "run.hpp"

namespace pointfair::tiles::detail {

// ---- neighbourhoods ---------------------------------------------------------------------------

bool Run::covers_all(std::size_t t, double halo) const { return covers_all(tiles_.bounds[t], halo); }

bool Run::covers_all(const Box& b, double halo) const {
  for (std::size_t c = 0; c < 3; ++c)
    if (b[c] - halo > global_bounds_[c] || b[c + 3] + halo < global_bounds_[c + 3]) return false;
  return true;
}

double Run::first_halo(std::size_t t) const {
  if (std::isfinite(eps_) && eps_ > 0.0) return eps_ * (1.0 + 1e-6);
  return knn_first_halo(t, k());
}

double Run::knn_first_halo(std::size_t t, int neighbors) const {
  return knn_first_halo(tiles_.bounds[t], tiles_.rows(t), neighbors);
}

double Run::knn_first_halo(const Box& b, std::uint64_t box_rows, int neighbors) const {
  // Unbounded eps: start from the radius of a disc holding k+1 points of a surface patch as
  // dense as the tile (its side over the square root of its points, times sqrt((k+1)/pi)),
  // with a margin of 1.5, and grow until every (k+1)-th neighbour lies inside the halo. (Twice
  // the patch's spacing times sqrt(k+1), as before, gathered a halo three times as wide:
  // for the finish's 200 neighbours, many times the tile.) A tile of few points in a wide box
  // (a sliver of a surface that crosses it) would still start with a halo of many times its
  // points: it starts no wider than four times the halo of the whole cloud taken as one such
  // patch.
  const Box& g = global_bounds_;
  const double side = std::max({b[3] - b[0], b[4] - b[1], b[5] - b[2], 0.0});
  const double cloud_side = std::max({g[3] - g[0], g[4] - g[1], g[5] - g[2], 0.0});
  const double diag = std::hypot(g[3] - g[0], g[4] - g[1], g[5] - g[2]);
  const double rows = static_cast<double>(std::max<std::uint64_t>(1, box_rows));
  const double points = static_cast<double>(std::max<std::uint64_t>(1, n_));
  const double disc = 1.5 * std::sqrt((neighbors + 1.0) / std::numbers::pi);
  const double tile_guess = disc * side / std::sqrt(rows);
  const double cloud_guess = disc * cloud_side / std::sqrt(points);
  return std::max(std::min(tile_guess, 4.0 * cloud_guess), 1e-12 * (1.0 + diag));
}

LocalSet Run::gather_local(std::size_t t, double halo) const {
  std::optional<LocalSet> s = gather_part(t, halo, {.box = tiles_.bounds[t], .rows = {}},
                                          std::numeric_limits<std::uint64_t>::max());
  assert(s && "gathering without a limit always gives a set");
  return std::move(*s);
}

std::optional<LocalSet> Run::gather_part(std::size_t t, double halo, const TilePart& part,
                                         std::uint64_t max_points) const {
  const h5::Dataset pos = file().dataset(neighbor_source_);
  const h5::Dataset orig = file().dataset(layout::original_index);
  const Box& tile_box = tiles_.bounds[t];
  const Box& own = part.box;
  Box grown = own;
  for (std::size_t c = 0; c < 3; ++c) {
    grown[c] -= halo;
    grown[c + 3] += halo;
  }
  struct Entry {
    std::uint64_t original, row;
    Vec3 p;
    std::int64_t query;  // the entry's place among the part's rows, or -1
  };
  const bool whole = part.rows.empty();
  const std::uint64_t queries = whole ? tiles_.rows(t) : part.rows.size();
  std::size_t next_part_row = 0;  // part.rows ascend, as the tile's rows are read
  std::vector<Entry> entries;
  std::vector<double> xyz;
  std::vector<std::uint64_t> index;
  for (std::size_t u = 0; u < tiles_.size(); ++u) {
    if (tiles_.rows(u) == 0 || (u != t && !intersects(own, halo, tiles_.bounds[u]))) continue;
    for (std::uint64_t first = tiles_.offsets[u]; first < tiles_.offsets[u + 1]; first += kScanBlock) {
      const std::uint64_t count = std::min(kScanBlock, tiles_.offsets[u + 1] - first);
      xyz.resize(3 * count);
      index.resize(count);
      pos.read_rows(first, count, xyz.data());
      orig.read_rows(first, count, index.data());
      for (std::uint64_t r = 0; r < count; ++r) {
        const Vec3 p(xyz[3 * r], xyz[3 * r + 1], xyz[3 * r + 2]);
        if (!p.allFinite())
          file().fail(neighbor_source_, "row " + std::to_string(first + r) + " has a non-finite coordinate");
        std::int64_t query = -1;
        if (u == t) {
          // The halos of the other tiles are found through this tile's bounds: a point outside
          // them (a container that contradicts itself) would silently change the result.
          for (std::size_t c = 0; c < 3; ++c) {
            const double v = p[static_cast<Eigen::Index>(c)];
            if (!(v >= tile_box[c] && v <= tile_box[c + 3]))
              file().fail(layout::tile_bounds, "row " + std::to_string(first + r) +
                                                   " lies outside the bounds of its tile " + std::to_string(t) +
                                                   ": the container contradicts itself (import the point file again)");
          }
          const std::uint64_t tile_row = first + r - tiles_.offsets[t];
          if (whole) {
            query = static_cast<std::int64_t>(tile_row);
          } else if (next_part_row < part.rows.size() && part.rows[next_part_row] == tile_row) {
            query = static_cast<std::int64_t>(next_part_row++);
          }
        }
        bool inside = query >= 0;
        if (!inside) {
          inside = true;
          for (std::size_t c = 0; c < 3 && inside; ++c)
            inside = p[static_cast<Eigen::Index>(c)] >= grown[c] && p[static_cast<Eigen::Index>(c)] <= grown[c + 3];
        }
        if (!inside) continue;
        if (entries.size() >= max_points) return std::nullopt;
        entries.push_back({index[r], first + r, p, query});
      }
    }
  }
  assert(whole || next_part_row == part.rows.size());
  // Local indices ascending with the original index: the tie rule of the canonical order.
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.original < b.original; });
  LocalSet s;
  s.positions.reserve(entries.size());
  s.rows.reserve(entries.size());
  s.original.reserve(entries.size());
  s.queries.assign(queries, 0);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    s.positions.push_back(entries[i].p);
    s.rows.push_back(entries[i].row);
    s.original.push_back(entries[i].original);
    if (entries[i].query >= 0) s.queries[static_cast<std::size_t>(entries[i].query)] = static_cast<Index>(i);
  }
  return s;
}

template <class Measure>
void Run::for_each_sample_knn(std::uint64_t stride, int want, const char* stage, Measure&& measure) {
  const h5::Dataset orig = file().dataset(layout::original_index);
  std::vector<std::uint64_t> index;
  const double saved_eps = eps_;
  eps_ = std::numeric_limits<double>::infinity();  // first_halo: grow from the tile's spacing
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t rows = tiles_.rows(t);
    if (rows == 0) continue;
    index.resize(rows);
    orig.read_rows(tiles_.offsets[t], rows, index.data());
    std::vector<std::pair<std::uint64_t, std::uint64_t>> mine;  // (sample, row in tile)
    for (std::uint64_t r = 0; r < rows; ++r)
      if (index[r] % stride == 0) mine.emplace_back(index[r] / stride, r);
    if (mine.empty()) continue;
    for (double halo = first_halo(t);; halo *= 2.0) {
      const LocalSet local = gather_local(t, halo);
      std::vector<Index> queries(mine.size());
      for (std::size_t i = 0; i < mine.size(); ++i) queries[i] = local.queries[mine[i].second];
      const NearestPoints near = nearest_points(local.positions, queries, want);
      // The cell grid held about 48 bytes a point while it searched.
      account(local.bytes() + local.positions.size() * 48 + bytes(queries) + bytes(near.indices) +
              bytes(near.distances2) + bytes(near.counts));
      const bool all = covers_all(t, halo);
      std::atomic<bool> ok{true};
      parallel_for(mine.size(), [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          const std::span<const Index> idx = near.indices_of(i);
          const std::span<const double> d2 = near.distances2_of(i);
          const int found = near.counts[i];
          // Settled when the halo holds all `want` points: the farthest lies inside it.
          if (!all && (found < want || !(std::sqrt(d2[static_cast<std::size_t>(found - 1)]) < halo * (1.0 - kHaloMargin)))) {
            ok = false;
            continue;
          }
          measure(mine[i].first, idx, d2, local.positions, queries[i]);
        }
      }, 64);
      if (ok) break;
    }
    progress(stage, t + 1 - first_tile_, end_tile_ - first_tile_);
  }
  eps_ = saved_eps;
}

double Run::resolve_eps_tiled() {
  NeighborParams np = params_.neighbors;
  np.validate();
  if (np.eps > 0.0) return np.eps;
  if (n_ < 2) return std::numeric_limits<double>::infinity();
  // The in-core resolve_eps: median distance to the (k+1)-th nearest point (the point itself
  // included) over the points with original index s * stride.
  const std::uint64_t stride = std::max<std::uint64_t>(1, n_ / 65536);
  const std::uint64_t samples = (n_ + stride - 1) / stride;
  const int want = static_cast<int>(std::min<std::uint64_t>(static_cast<std::uint64_t>(k()) + 1, n_));
  std::vector<double> kth(samples, 0.0);
  for_each_sample_knn(stride, want, "eps",
                      [&](std::uint64_t sample, std::span<const Index>, std::span<const double> d2,
                          std::span<const Vec3>, Index) { kth[sample] = d2.empty() ? 0.0 : std::sqrt(d2.back()); });
  ranks_->max(kth);  // each sample was measured by the rank of its tile, 0 elsewhere
  auto mid = kth.begin() + static_cast<std::ptrdiff_t>(samples / 2);
  std::nth_element(kth.begin(), mid, kth.end());
  const double spacing = *mid;
  if (!(spacing > 0.0)) return std::numeric_limits<double>::infinity();
  return np.eps_auto_factor * spacing;
}

void Run::open_step0_positions() {
  read_input_tables();
  const fs::path& source = options_.start_positions.empty() ? input_path_ : options_.start_positions;
  file_.emplace(h5::File::open(source, false));
  if (!options_.start_positions.empty()) {
    // The start's own tile bounds (its points are not the input's); the same rows.
    const TileTable start = read_tile_table(file());
    if (start.offsets != tiles_.offsets)
      file().fail(layout::tile_offsets, "the start positions' tiles are not those of " + input_path_.string());
    tiles_.bounds = start.bounds;
    global_bounds_ = cloud_bounds(tiles_);
  }
}

NoiseEstimate Run::measure_noise() {
  open_step0_positions();
  balance(false);
  const NoiseEstimate estimate = noise_tiled();
  file_.reset();
  read_input_tables();
  return estimate;
}

NoiseEstimate Run::noise_tiled() {
  // estimate_noise(): the noise ratio of the points with original index s * stride, each over
  // its kNoiseProbePoints nearest points, found in the tile and a halo that holds them all,
  // and the median distance from them to their nearest other point.
  if (n_ < 8) return {};
  const std::uint64_t stride = noise_sample_stride(n_);
  const std::uint64_t samples = (n_ + stride - 1) / stride;
  const int want = static_cast<int>(std::min<std::uint64_t>(kNoiseProbePoints, n_));
  // -1: not this rank's sample; -0.5: measured, not usable (NaN, which a max would not carry).
  std::vector<double> ratios(samples, -1.0), nearest_d2(samples, -1.0);
  for_each_sample_knn(stride, want, "k",
                      [&](std::uint64_t sample, std::span<const Index> idx, std::span<const double> d2,
                          std::span<const Vec3> positions, Index self) {
                        std::vector<ProbePoint> probe;
                        probe.reserve(idx.size());
                        for (std::size_t j = 0; j < idx.size(); ++j) probe.push_back({d2[j], positions[idx[j]]});
                        const double g = noise_ratio(probe, probe.size() == n_);
                        ratios[sample] = std::isfinite(g) ? g : -0.5;
                        double closest = std::numeric_limits<double>::infinity();
                        for (std::size_t j = 0; j < idx.size(); ++j)
                          if (idx[j] != self) closest = std::min(closest, d2[j]);
                        nearest_d2[sample] = closest;
                      });
  ranks_->max(ratios);  // each sample was measured by the rank of its tile
  ranks_->max(nearest_d2);
  for (double& g : ratios)
    if (g < 0.0) g = std::numeric_limits<double>::quiet_NaN();
  return noise_estimate_of(ratios, std::move(nearest_d2));
}

void Run::build_neighbors(int step) {
  eps_ = resolve_eps_tiled();
  h5::Dataset rows_ds = file().dataset(layout::neighbor_rows);
  h5::Dataset counts_ds = file().dataset(layout::neighbor_counts);
  const std::size_t stride = static_cast<std::size_t>(k());
  h5::Dataset halo_ds = file().dataset(layout::neighbor_halo_counts);
  std::vector<std::uint32_t> out, outside;
  const std::uint64_t writes = tiles_to_write();
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t rows = tiles_.rows(t);
    if (rows == 0) continue;
    for (double halo = first_halo(t);; halo *= 2.0) {
      LocalSet local = gather_local(t, halo);
      const Neighborhoods nb = build_neighborhoods(local.positions, local.queries, k(), eps_);
      // Exact when the halo holds every point within eps, or, for a larger eps, when every
      // point's (k+1)-th nearest point lies inside the halo.
      bool ok = std::isfinite(eps_) || covers_all(t, halo);
      if (!ok) {
        ok = true;
        for (std::size_t r = 0; r < nb.size() && ok; ++r) {
          if (nb.counts[r] < k()) {
            ok = false;
            break;
          }
          const Vec3& q = local.positions[local.queries[r]];
          const Vec3& last = local.positions[nb.indices[r * stride + stride - 1]];
          ok = (last - q).norm() < halo * (1.0 - kHaloMargin);
        }
      }
      if (!ok) continue;
      largest_local_ = std::max<std::uint64_t>(largest_local_, local.positions.size());
      out.resize(rows * stride);
      for (std::size_t r = 0; r < nb.size(); ++r)
        for (std::size_t j = 0; j < stride; ++j)
          out[r * stride + j] = j < nb.counts[r] ? static_cast<std::uint32_t>(local.rows[nb.indices[r * stride + j]]) : 0u;
      account(local.bytes() + local.positions.size() * 16 + bytes(nb.indices) + bytes(nb.counts) + bytes(out));
      rows_ds.write_rows(tiles_.offsets[t], rows, out.data(), h5::Transfer::Collective);
      counts_ds.write_rows(tiles_.offsets[t], rows, nb.counts.data(), h5::Transfer::Collective);
      // The halo a step reads: the distinct neighbours outside the tile (balances the steps).
      outside.clear();
      for (std::size_t r = 0; r < nb.size(); ++r)
        for (std::size_t j = 0; j < nb.counts[r]; ++j) {
          const std::uint32_t g = out[r * stride + j];
          if (g < tiles_.offsets[t] || g >= tiles_.offsets[t + 1]) outside.push_back(g);
        }
      std::sort(outside.begin(), outside.end());
      const std::uint64_t halo_count =
          static_cast<std::uint64_t>(std::unique(outside.begin(), outside.end()) - outside.begin());
      halo_ds.write_rows(t, 1, &halo_count, h5::Transfer::Collective);
      break;
    }
    progress("neighbors", t + 1 - first_tile_, end_tile_ - first_tile_);
  }
  for (std::uint64_t w = my_tiles(); w < writes; ++w) {
    rows_ds.write_rows<std::uint32_t>(0, 0, nullptr, h5::Transfer::Collective);
    counts_ds.write_rows<std::uint16_t>(0, 0, nullptr, h5::Transfer::Collective);
    halo_ds.write_rows<std::uint64_t>(0, 0, nullptr, h5::Transfer::Collective);
  }
  if (ranks_->rank() == 0) file().dataset(layout::run_eps).write_rows(0, 1, &eps_);
  state_[kNeighborsDone] = 1;
  state_[kNeighborsStep] = step;
  commit_state();
}

void Run::load_start() {
  // The same tiles and rows: this rank's rows copied a block at a time.
  const h5::File start = h5::File::open(options_.start_positions, false);
  const h5::Dataset source = start.dataset(layout::positions);
  if (source.rows() != n_ || source.width() != 3)
    start.fail(layout::positions, "has " + std::to_string(source.rows()) + " rows, " + input_path_.string() + " has " +
                                      std::to_string(n_) + " points");
  h5::Dataset target = file().dataset(kStartPositions);
  // Blocks of a 64th of the budget.
  const std::uint64_t rows = std::clamp<std::uint64_t>(options_.memory_budget / 64 / sizeof(Vec3), 1024, kScanBlock);
  std::vector<Vec3> block;
  for (std::uint64_t first = my_first_row(); first < my_end_row(); first += rows) {
    const std::uint64_t count = std::min(rows, my_end_row() - first);
    block.resize(count);
    source.read_rows(first, count, block.data()->data());
    for (std::uint64_t r = 0; r < count; ++r)
      if (!block[r].allFinite())
        start.fail(layout::positions, "row " + std::to_string(first + r) + " has a non-finite coordinate");
    target.write_rows(first, count, block.data()->data());
  }
  account(bytes(block));
  file().flush();  // every rank's rows before any rank gathers a halo of them
}

void Run::load_reference() {
  // The reference lists its points in the input's original order; rows hold them in tile
  // order. In passes over blocks of original indices that fit in an eighth of the budget: read the
  // block from the reference (streamed from its start), then put each of this rank's rows
  // whose original index falls in it.
  const fs::path& path = options_.neighbor_reference;
  const auto open = [&]() -> std::unique_ptr<io::PointChunkReader> {
    std::string e = path.extension().string();
    for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (e == ".h5" || e == ".hdf5") return std::make_unique<ContainerChunkReader>(path);
    return io::open_point_reader(path);
  };
  const h5::Dataset orig = file().dataset(layout::original_index);
  h5::Dataset target = file().dataset(kReferencePositions);
  constexpr std::size_t kChunk = 1u << 14;
  const std::uint64_t block = std::max<std::uint64_t>(1024, options_.memory_budget / 8 / sizeof(Vec3));
  std::vector<Vec3> values, rows;
  std::vector<std::uint64_t> index;
  io::PointTable chunk;
  for (std::uint64_t a = 0; a < std::max<std::uint64_t>(n_, 1); a += block) {
    const std::uint64_t b = std::min(n_, a + block);
    values.assign(b - a, Vec3::Zero());
    const auto reader = open();
    std::uint64_t at = 0;
    // The first pass reads the whole reference, to check its size.
    while (a == 0 || at < b) {
      const std::size_t got = reader->read(chunk, kChunk);
      if (got == 0) break;
      for (std::size_t i = 0; i < got; ++i)
        if (at + i >= a && at + i < b) values[at + i - a] = chunk.positions[i];
      at += got;
      account(bytes(values) + bytes(chunk.positions) + chunk.attributes.size() * kChunk * sizeof(double));
    }
    if (a == 0 && at != n_)
      throw ParamError(path.string() + ": has " + std::to_string(at) + " points, " + input_path_.string() + " has " +
                       std::to_string(n_) + " (--neighbors-from needs the input's points in the same order)");
    for (std::uint64_t first = my_first_row(); first < my_end_row(); first += kScanBlock) {
      const std::uint64_t count = std::min(kScanBlock, my_end_row() - first);
      index.resize(count);
      orig.read_rows(first, count, index.data());
      const bool all = std::all_of(index.begin(), index.end(), [&](std::uint64_t o) { return o >= a && o < b; });
      const bool any = all || std::any_of(index.begin(), index.end(), [&](std::uint64_t o) { return o >= a && o < b; });
      if (!any) continue;
      rows.resize(count);
      if (!all) target.read_rows(first, count, rows.data()->data());
      for (std::uint64_t r = 0; r < count; ++r)
        if (index[r] >= a && index[r] < b) rows[r] = values[index[r] - a];
      target.write_rows(first, count, rows.data()->data());
    }
  }
  free_vector(values);
}

void Run::measure_bounds() {
  // Points move: the halo of a rebuild needs the bounds of every tile's current points. Each
  // rank measures its own tiles; the maximum of (-min, max) over the ranks is every tile's.
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::vector<double> extent(6 * tiles_.size(), -inf);
  const h5::Dataset pos = file().dataset(neighbor_source_);
  std::vector<Vec3> block;
  for (std::size_t t = first_tile_; t < end_tile_; ++t)
    for (std::uint64_t first = tiles_.offsets[t]; first < tiles_.offsets[t + 1]; first += kScanBlock) {
      const std::uint64_t count = std::min(kScanBlock, tiles_.offsets[t + 1] - first);
      block.resize(count);
      pos.read_rows(first, count, block.data()->data());
      for (const Vec3& p : block)
        for (Eigen::Index c = 0; c < 3; ++c) {
          const std::size_t i = 6 * t + static_cast<std::size_t>(c);
          extent[i] = std::max(extent[i], -p[c]);
          extent[i + 3] = std::max(extent[i + 3], p[c]);
        }
    }
  ranks_->max(extent);
  global_bounds_ = {inf, inf, inf, -inf, -inf, -inf};
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    if (tiles_.rows(t) == 0) continue;
    for (std::size_t c = 0; c < 3; ++c) {
      tiles_.bounds[t][c] = -extent[6 * t + c];
      tiles_.bounds[t][c + 3] = extent[6 * t + c + 3];
      global_bounds_[c] = std::min(global_bounds_[c], tiles_.bounds[t][c]);
      global_bounds_[c + 3] = std::max(global_bounds_[c + 3], tiles_.bounds[t][c + 3]);
    }
  }
}

void Run::rebuild_neighbors(int step) {
  // smooth()'s rebuild: eps resolved again and the lists built from the step's positions,
  // over the same tiles with a geometric halo around their current bounds. The halo scratch
  // is of the old halos (made again for the new ones by the next streamed step).
  release_scratch();
  neighbor_source_ = current_source();
  measure_bounds();
  build_neighbors(step);
  // The lists in memory and in tile-local indices are the old ones, and so are the halos of
  // the positions held in memory.
  release_positions();
  cache_.assign(tiles_.size(), {});
  cache_bytes_ = 0;
  caching_ = true;
  local_written_.assign(tiles_.size(), 0);
  halo_rows_.assign(tiles_.size(), {});
  halo_bytes_ = 0;
  if (auto_lambda_on()) {
    prepare_lambda_sample();
    load_sample_positions(file().dataset(neighbor_source_));
  }
}

// ---- the lambda sample ------------------------------------------------------------------------

void Run::prepare_lambda_sample() {
  if (n_ == 0) return;
  // The in-core auto_lambda: the points with original index s * stride, stride = n / 8192.
  const std::uint64_t stride = std::max<std::uint64_t>(1, n_ / 8192);
  const std::uint64_t samples = (n_ + stride - 1) / stride;
  sample_rows_.assign(samples, 0);
  const h5::Dataset orig = file().dataset(layout::original_index);
  std::vector<std::uint64_t> index;
  // Each rank finds the samples among its rows (0 elsewhere); the maximum over the ranks is
  // every sample's row.
  for (std::uint64_t first = my_first_row(); first < my_end_row(); first += kScanBlock) {
    const std::uint64_t count = std::min(kScanBlock, my_end_row() - first);
    index.resize(count);
    orig.read_rows(first, count, index.data());
    for (std::uint64_t r = 0; r < count; ++r)
      if (index[r] % stride == 0) sample_rows_[index[r] / stride] = first + r;
  }
  ranks_->max(sample_rows_);
  // Gathered (its lists and the positions of every row they name, about 14 MiB for 8192
  // samples of 48 neighbours) while that takes at most the room kept for it, or 2 MiB (a
  // small cloud's sample, gathered as it always was); else each lambda reads them in pieces,
  // and a small budget keeps its room for the tiles.
  const std::size_t kk = static_cast<std::size_t>(k());
  const std::uint64_t gathered_bound =
      std::min<std::uint64_t>(samples * (kk + 1), n_) * (sizeof(std::uint64_t) + sizeof(Vec3)) +
      samples * (kk * sizeof(Index) + sizeof(std::uint16_t) + sizeof(Index));
  sample_gathered_ = gathered_bound <= std::max(lambda_sample_room(options_.memory_budget), std::uint64_t{2} << 20);
  if (!sample_gathered_) {
    free_vector(sample_local_);
    free_vector(sample_neighbors_);
    free_vector(sample_counts_);
    free_vector(gather_rows_);
    free_vector(gather_positions_);
    return;
  }
  std::vector<std::uint64_t> sorted = sample_rows_;
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::uint32_t> lists(sorted.size() * kk);
  std::vector<std::uint16_t> counts(sorted.size());
  file().dataset(layout::neighbor_rows).read_selected(sorted, lists.data());
  file().dataset(layout::neighbor_counts).read_selected(sorted, counts.data());
  gather_rows_ = sorted;
  for (std::size_t i = 0; i < sorted.size(); ++i)
    for (std::size_t j = 0; j < counts[i]; ++j) gather_rows_.push_back(lists[i * kk + j]);
  std::sort(gather_rows_.begin(), gather_rows_.end());
  gather_rows_.erase(std::unique(gather_rows_.begin(), gather_rows_.end()), gather_rows_.end());
  gather_rows_.shrink_to_fit();
  auto local_of = [&](std::uint64_t row) {
    return static_cast<Index>(std::lower_bound(gather_rows_.begin(), gather_rows_.end(), row) - gather_rows_.begin());
  };
  sample_local_.resize(samples);
  sample_counts_.resize(samples);
  sample_neighbors_.assign(samples * kk, 0);
  for (std::uint64_t s = 0; s < samples; ++s) {
    const std::size_t i = static_cast<std::size_t>(std::lower_bound(sorted.begin(), sorted.end(), sample_rows_[s]) - sorted.begin());
    sample_local_[s] = local_of(sample_rows_[s]);
    sample_counts_[s] = counts[i];
    for (std::size_t j = 0; j < counts[i]; ++j) sample_neighbors_[s * kk + j] = local_of(lists[i * kk + j]);
  }
}

void Run::load_sample_positions(const h5::Dataset& positions) {
  sample_source_ = positions.path();
  if (!sample_gathered_) return;
  gather_positions_.resize(gather_rows_.size());
  if (!gather_rows_.empty()) positions.read_selected(gather_rows_, gather_positions_.data()->data());
}

double Run::sample_lambda() {
  // auto_lambda (euler_step.cpp) on the gathered sample: the same points and the same
  // per-point and global medians; tests check that both agree to the bit.
  if (n_ == 0) return 1.0;
  if (!sample_gathered_) return sample_lambda_in_pieces();
  const std::size_t samples = sample_rows_.size();
  const std::size_t kk = static_cast<std::size_t>(k());
  const std::span<const Vec3> points = gather_positions_;
  std::vector<double> medians(samples, -1.0);
  parallel_for(samples, [&](std::size_t begin, std::size_t end) {
    for (std::size_t s = begin; s < end; ++s) {
      const Index i = sample_local_[s];
      const std::span<const Index> nb(sample_neighbors_.data() + s * kk, sample_counts_[s]);
      medians[s] = median_abs_curvature(points[i], nb, points);
    }
  }, 256);
  return lambda_from_medians(std::move(medians), params_.flow.lambda_auto_factor);
}

double Run::sample_lambda_in_pieces() {
  // The same medians as sample_lambda's, of this rank's samples in row order, kPiece at a
  // time: the piece's lists, then the positions of the rows they name, read from the run
  // file (sample_source_, in row order). A piece of consecutive rows lies in a few
  // neighbouring tiles, so that its reads are short runs of nearby rows.
  constexpr std::size_t kPiece = 256;
  const std::size_t samples = sample_rows_.size(), kk = static_cast<std::size_t>(k());
  std::vector<std::pair<std::uint64_t, std::size_t>> mine;  // (row, sample)
  for (std::size_t s = 0; s < samples; ++s)
    if (sample_rows_[s] >= my_first_row() && sample_rows_[s] < my_end_row()) mine.emplace_back(sample_rows_[s], s);
  std::sort(mine.begin(), mine.end());
  const h5::Dataset positions = file().dataset(sample_source_);
  const h5::Dataset list_rows = file().dataset(layout::neighbor_rows);
  const h5::Dataset list_counts = file().dataset(layout::neighbor_counts);
  // +0.0 where another rank measures (Ranks::merge).
  std::vector<double> medians(samples, 0.0);
  std::vector<std::uint64_t> rows, gather;
  std::vector<std::uint32_t> lists;
  std::vector<std::uint16_t> counts;
  std::vector<Vec3> points;
  std::vector<Index> local;
  for (std::size_t first = 0; first < mine.size(); first += kPiece) {
    const std::size_t count = std::min(kPiece, mine.size() - first);
    rows.resize(count);
    for (std::size_t i = 0; i < count; ++i) rows[i] = mine[first + i].first;
    lists.resize(count * kk);
    counts.resize(count);
    list_rows.read_selected(rows, lists.data());
    list_counts.read_selected(rows, counts.data());
    gather = rows;
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t j = 0; j < counts[i]; ++j) gather.push_back(lists[i * kk + j]);
    std::sort(gather.begin(), gather.end());
    gather.erase(std::unique(gather.begin(), gather.end()), gather.end());
    points.resize(gather.size());
    positions.read_selected(gather, points.data()->data());
    const auto local_of = [&](std::uint64_t row) {
      return static_cast<Index>(std::lower_bound(gather.begin(), gather.end(), row) - gather.begin());
    };
    local.resize(count * kk);
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t j = 0; j < counts[i]; ++j) local[i * kk + j] = local_of(lists[i * kk + j]);
    account(bytes(rows) + bytes(gather) + bytes(lists) + bytes(counts) + bytes(points) + bytes(local) + bytes(mine) +
            bytes(medians));
    parallel_for(count, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const std::span<const Index> nb(local.data() + i * kk, counts[i]);
        medians[mine[first + i].second] = median_abs_curvature(points[local_of(rows[i])], nb, points);
      }
    }, 16);
  }
  if (ranks_->size() > 1) ranks_->merge(medians);
  return lambda_from_medians(std::move(medians), params_.flow.lambda_auto_factor);
}

}  // namespace pointfair::tiles::detail
