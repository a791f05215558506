// The quadric finish out of core, the attributes and the end of the run.
#include "run.hpp"

namespace pointfair::tiles::detail {

// ---- the quadric finish -------------------------------------------------------------------------

namespace {

// Whether the ball of radius `reach` around p lies inside box `own` grown by `halo`: the
// points gathered around a part.
bool gathered_around(const Box& own, double halo, const Vec3& p, double reach) {
  for (Eigen::Index c = 0; c < 3; ++c) {
    const std::size_t lo = static_cast<std::size_t>(c), hi = lo + 3;
    if (!(p[c] - reach > own[lo] - halo && p[c] + reach < own[hi] + halo)) return false;
  }
  return true;
}

// Whether `row` (point i's nearest, `want` long in core) is certain to be the in-core one: it is
// that long and all of it was gathered. A point of the part lies in its box, so that its
// row's farthest entry within the halo suffices; another point's whole ball must lie inside
// what was gathered.
bool certain_row(const Box& own, double halo, std::span<const Vec3> positions, Index i, bool of_part,
                 std::span<const Index> row, std::size_t want) {
  if (row.size() < want || row.empty()) return false;
  const double farthest = (positions[row.back()] - positions[i]).norm();
  return of_part ? farthest < halo * (1.0 - kHaloMargin)
                 : gathered_around(own, halo, positions[i], farthest + halo * kHaloMargin);
}

}  // namespace

std::optional<FinishLists> Run::finish_lists(const Box& own, double halo, const LocalSet& local,
                                             const QuadricProjectionParams& q) const {
  // finish_with_quadrics's lists on a tile's (or a part's, in box `own`) gathered points (sorted by original index: the
  // canonical tie rule). Empty (the halo must grow) unless every row is certain to be the
  // in-core one: its farthest entry lies inside what was gathered. With fit sharing a tile
  // point's row holds only its share_candidates nearest (the crease test's and the seeds'),
  // as in core: the points left to fit their own get k-long rows after the projection
  // (own_fit_rows).
  constexpr double inf = std::numeric_limits<double>::infinity();
  const std::size_t n = local.positions.size(), kk = static_cast<std::size_t>(q.k);
  const bool sharing = q.share_stride > 1;
  const std::size_t row_k = sharing ? share_candidates(q) : kk;
  const bool all = covers_all(own, halo);
  FinishLists lists;
  lists.fits = build_neighborhoods(local.positions, local.queries, static_cast<int>(row_k), inf);
  std::vector<char> in_tile(n, 0), named(n, 0);
  for (const Index i : local.queries) in_tile[i] = 1;
  // Whether `row` (point i's, `want` long in core) is the in-core one (certain_row); its
  // points named.
  const auto check_row = [&](std::span<const Index> row, Index i, std::size_t want) {
    if (!all && !certain_row(own, halo, local.positions, i, in_tile[i] != 0, row, want)) return false;
    for (const Index j : row) named[j] = !in_tile[j];
    return true;
  };
  for (std::size_t r = 0; r < lists.fits.size(); ++r)
    if (!check_row(lists.fits.of(r), local.queries[r], row_k)) return std::nullopt;
  if (sharing) {
    // The seeds a tile point may share the fit of (its row: its first share_candidates), in
    // ascending local order, each with its own fit's k-long row.
    std::vector<char> seed(n, 0);
    for (std::size_t r = 0; r < lists.fits.size(); ++r) {
      for (const Index j : lists.fits.of(r)) seed[j] = 1;
      seed[local.queries[r]] = 1;
    }
    for (std::size_t i = 0; i < n; ++i)
      if (seed[i] && is_share_seed(local.original[i], q)) lists.seed_queries.push_back(static_cast<Index>(i));
    lists.seed_fits = build_neighborhoods(local.positions, lists.seed_queries, q.k, inf);
    for (std::size_t r = 0; r < lists.seed_fits.size(); ++r)
      if (!check_row(lists.seed_fits.of(r), lists.seed_queries[r], kk)) return std::nullopt;
  }
  std::vector<Index> halo_queries;
  for (std::size_t i = 0; i < n; ++i)
    if (named[i]) halo_queries.push_back(static_cast<Index>(i));
  // A normal reads the first normal_neighbors of the point's row; a prefix of the canonical
  // order is the canonical order of fewer neighbours.
  const int m = std::min(q.k, q.normal_neighbors);
  const Neighborhoods near = build_neighborhoods(local.positions, halo_queries, m, inf);
  if (!all) {
    // A halo point's ball lies inside the box around the tile that was gathered.
    for (std::size_t r = 0; r < near.size(); ++r)
      if (!certain_row(own, halo, local.positions, halo_queries[r], false, near.of(r), static_cast<std::size_t>(m)))
        return std::nullopt;
  }
  // The normals' rows: the tile's points and the halo points the fits name; the others empty.
  Neighborhoods& normal_rows = lists.normals;
  normal_rows.stride = m;
  normal_rows.eps = inf;
  normal_rows.counts.assign(n, 0);
  normal_rows.indices.assign(n * static_cast<std::size_t>(m), 0);
  const auto put = [&](std::span<const Index> row, Index i) {
    const std::size_t count = std::min(row.size(), static_cast<std::size_t>(m));
    std::copy(row.begin(), row.begin() + static_cast<std::ptrdiff_t>(count),
              normal_rows.indices.begin() + static_cast<std::ptrdiff_t>(i * static_cast<std::size_t>(m)));
    normal_rows.counts[i] = static_cast<std::uint16_t>(count);
  };
  for (std::size_t r = 0; r < lists.fits.size(); ++r) put(lists.fits.of(r), local.queries[r]);
  for (std::size_t r = 0; r < near.size(); ++r) put(near.of(r), halo_queries[r]);
  // A halo seed is named by a tile point's row: its normal's row is among the halo's.
  assert(std::ranges::all_of(lists.seed_queries, [&](Index i) { return normal_rows.counts[i] > 0 || n == 1; }));
  lists.near_bytes = bytes(near.indices) + bytes(near.counts) + bytes(halo_queries) + 2 * n;
  return lists;
}

std::optional<OwnFitRows> Run::own_fit_rows(const Box& own, double halo, const LocalSet& local,
                                            std::span<const Index> queries, std::span<const char> has_normal,
                                            const QuadricProjectionParams& q) const {
  // As finish_lists's rows: canonical on the gathered points in their original order, and
  // certain to be the in-core ones or none.
  constexpr double inf = std::numeric_limits<double>::infinity();
  const bool all = covers_all(own, halo);
  const std::size_t kk = static_cast<std::size_t>(q.k);
  OwnFitRows rows;
  rows.fits = build_neighborhoods(local.positions, queries, q.k, inf);
  std::vector<char> named(local.positions.size(), 0);
  for (std::size_t r = 0; r < rows.fits.size(); ++r) {
    const std::span<const Index> row = rows.fits.of(r);
    // The queries are the part's points.
    if (!all && !certain_row(own, halo, local.positions, queries[r], true, row, kk)) return std::nullopt;
    for (const Index j : row)
      if (!has_normal[j] && !named[j]) {
        named[j] = 1;
        rows.named.push_back(j);
      }
  }
  std::sort(rows.named.begin(), rows.named.end());
  const int m = std::min(q.k, q.normal_neighbors);
  rows.normals = build_neighborhoods(local.positions, rows.named, m, inf);
  if (!all)
    for (std::size_t r = 0; r < rows.normals.size(); ++r)
      if (!certain_row(own, halo, local.positions, rows.named[r], false, rows.normals.of(r), static_cast<std::size_t>(m)))
        return std::nullopt;
  return rows;
}

namespace {

// What finish_part holds for `gathered` points of which `queries` are the part's (fits of k,
// normals of m neighbours) and `seeds` have a shared fit: the gathered set (40 bytes a point;
// its entries, 48, while gathering), the cell grid (50), the normals' rows and those that
// built the halo's (8m + 10), the normals (24), the shared fits' index (4); each query's row
// in the set (4), its fit (4k + 2: with sharing its list is shorter, and the k-long lists of
// the queries left to fit their own come after the others are freed), its result and anchor
// (48); each seed's row (4k + 6) and fit.
std::uint64_t finish_part_bytes(std::uint64_t gathered, std::uint64_t queries, std::uint64_t seeds, int k, int m) {
  const auto mm = static_cast<std::uint64_t>(m), kk = static_cast<std::uint64_t>(k);
  return gathered * (40 + 50 + 8 * mm + 10 + 24 + 4) + queries * (4 + 4 * kk + 2 + 48) +
         seeds * (4 * kk + 6 + sizeof(QuadricFit));
}

// The seeds finish_part plans for with `queries` points of a part: twice their share (for
// the hash's spread and the halo's seeds), and those among one point's candidates (a small
// part's halo seeds); none without sharing. A part whose seeds outgrow the plan is split.
std::uint64_t planned_seeds(std::uint64_t queries, const QuadricProjectionParams& q) {
  return q.share_stride > 1 ? 2 * queries / static_cast<std::uint64_t>(q.share_stride) +
                                  static_cast<std::uint64_t>(share_candidates(q)) + 1
                            : 0;
}

// The box of `points`' rows `rows`.
Box box_of(std::span<const Vec3> points, std::span<const std::uint64_t> rows) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  Box b = {inf, inf, inf, -inf, -inf, -inf};
  for (const std::uint64_t r : rows)
    for (std::size_t c = 0; c < 3; ++c) {
      b[c] = std::min(b[c], points[r][static_cast<Eigen::Index>(c)]);
      b[c + 3] = std::max(b[c + 3], points[r][static_cast<Eigen::Index>(c)]);
    }
  return b;
}

// `part` (at least two rows) halved across the longest side of its box, each half with the
// box of its points.
std::array<TilePart, 2> split_part(const TilePart& part, std::span<const Vec3> points) {
  std::size_t axis = 0;
  for (std::size_t c = 1; c < 3; ++c)
    if (part.box[c + 3] - part.box[c] > part.box[axis + 3] - part.box[axis]) axis = c;
  const double lo = part.box[axis], hi = part.box[axis + 3], middle = lo + 0.5 * (hi - lo);
  std::array<TilePart, 2> halves;
  if (hi > lo) {
    for (const std::uint64_t r : part.rows) halves[points[r][static_cast<Eigen::Index>(axis)] < middle ? 0 : 1].rows.push_back(r);
  } else {
    // Every point at the same place: halves of the rows.
    const auto half = static_cast<std::ptrdiff_t>(part.rows.size() / 2);
    halves[0].rows.assign(part.rows.begin(), part.rows.begin() + half);
    halves[1].rows.assign(part.rows.begin() + half, part.rows.end());
  }
  for (TilePart& h : halves) h.box = box_of(points, h.rows);
  assert(!halves[0].rows.empty() && !halves[1].rows.empty());
  return halves;
}

}  // namespace

void Run::finish_tile(std::size_t t, const QuadricProjectionParams& q, std::span<const Vec3> anchors,
                      std::vector<Vec3>& result) {
  // One pass of finish_with_quadrics for tile t's points, from the positions in
  // neighbor_source_: into `result`, in row order; with `anchors` (the tile's input points,
  // in row order), the anchors placed on the fits instead. Each point's result depends on its
  // neighbours alone, so a tile whose halo would not fit the budget is finished in parts
  // (halved until each fits): the same bits.
  const std::uint64_t rows = tiles_.rows(t);
  result.resize(rows);
  std::uint64_t held = bytes(result) + anchors.size() * sizeof(Vec3);
  std::uint64_t needed = 0;
  TilePart whole{.box = tiles_.bounds[t], .rows = {}};
  if (finish_part(t, whole, q, anchors, result, held, needed)) return;
  ++finish_tiles_in_parts_;
  std::vector<Vec3> points(rows);
  file().dataset(neighbor_source_).read_rows(tiles_.offsets[t], rows, points.data()->data());
  held += bytes(points) + rows * sizeof(std::uint64_t);  // and the parts' rows
  whole.rows.resize(rows);
  std::iota(whole.rows.begin(), whole.rows.end(), std::uint64_t{0});
  std::vector<TilePart> parts;
  const auto split = [&](const TilePart& part) {
    // Not even one point's neighbours fit: refused with what that point needs.
    if (part.rows.size() < 2) refuse(persistent_bytes() + needed);
    for (TilePart& half : split_part(part, points)) parts.push_back(std::move(half));
  };
  split(whole);
  while (!parts.empty()) {
    TilePart part = std::move(parts.back());
    parts.pop_back();
    if (!finish_part(t, part, q, anchors, result, held, needed)) split(part);
  }
}

bool Run::finish_part(std::size_t t, const TilePart& part, const QuadricProjectionParams& q,
                      std::span<const Vec3> anchors, std::vector<Vec3>& result, std::uint64_t held,
                      std::uint64_t& needed) {
  const bool whole = part.rows.empty();
  const std::uint64_t queries = whole ? tiles_.rows(t) : part.rows.size();
  const int m = std::min(q.k, q.normal_neighbors);
  const std::uint64_t fixed = persistent_bytes() + held;
  const std::uint64_t per_point = finish_part_bytes(1, 0, 0, q.k, m);
  const std::uint64_t for_queries = finish_part_bytes(0, queries, planned_seeds(queries, q), q.k, m);
  needed = held + for_queries + queries * per_point;
  if (fixed + for_queries + queries * per_point > options_.memory_budget) return false;
  const std::uint64_t max_points = (options_.memory_budget - fixed - for_queries) / per_point;
  // What a halo of more than max_points would need (named when none fits).
  const std::uint64_t beyond = held + for_queries + (max_points + 1) * per_point;
  needed = beyond;
  std::vector<Vec3> part_result, part_anchors;
  for (double halo = knn_first_halo(part.box, queries, q.k);; halo *= 2.0) {
    std::optional<LocalSet> local = gather_part(t, halo, part, max_points);
    if (!local) {
      needed = beyond;
      return false;
    }
    std::optional<FinishLists> lists = finish_lists(part.box, halo, *local, q);
    needed = held + finish_part_bytes(local->positions.size(), queries,
                                      lists ? lists->seed_queries.size() : planned_seeds(queries, q), q.k, m);
    if (!lists) {
      account(needed);
      continue;
    }
    // More seeds than planned (their lists counted now) that do not fit: smaller parts.
    if (persistent_bytes() + needed > options_.memory_budget) return false;
    // The fits read each neighbour's position and normal: as in finish_with_quadrics, they run
    // on the gathered points stored in Morton order, the lists relabelled (each fit sees the
    // same neighbours in the same order: the same bits), so that those reads stay in cache.
    // The order and its inverse (8 bytes a point) take the room of the gathered points'
    // container rows and original indices (16), which nothing reads from here on.
    std::vector<std::uint64_t>().swap(local->rows);
    std::vector<std::uint64_t>().swap(local->original);
    const std::vector<Index> order = spatial_order(local->positions);
    const std::vector<Index> row_of = inverse_permutation(order);
    permute_in_place(local->positions, order);
    permute_neighborhoods_in_place(lists->normals, order, row_of);
    relabel_neighborhoods_in_place(lists->fits, row_of);
    relabel_neighborhoods_in_place(lists->seed_fits, row_of);
    for (Index& i : local->queries) i = row_of[i];
    for (Index& i : lists->seed_queries) i = row_of[i];
    std::vector<Vec3> normals = neighbourhood_normals(local->positions, lists->normals, q);
    // The seeds' fits, shared with their neighbours (as finish_with_quadrics's).
    SharedFits shared;
    if (q.share_stride > 1) {
      shared.fit_of.assign(local->positions.size(), SharedFits::kNoFit);
      shared.fits.resize(lists->seed_queries.size());
      fit_rows_to_quadrics(local->positions, normals, lists->seed_fits, lists->seed_queries, q, shared.fits);
      for (std::size_t r = 0; r < lists->seed_queries.size(); ++r) shared.fit_of[lists->seed_queries[r]] = static_cast<Index>(r);
    }
    const SharedFits* sharing = q.share_stride > 1 ? &shared : nullptr;
    if (!whole) {
      part_result.resize(queries);
      part_anchors.clear();
      if (!anchors.empty())
        for (const std::uint64_t r : part.rows) part_anchors.push_back(anchors[r]);
    }
    const std::span<Vec3> out = whole ? std::span<Vec3>(result) : std::span<Vec3>(part_result);
    const std::span<const Vec3> out_anchors = whole ? anchors : std::span<const Vec3>(part_anchors);
    // With sharing the points that fit their own are left for k-long rows (own_fit_rows).
    std::vector<char> left(sharing ? queries : 0, 0);
    project_rows_to_quadrics(local->positions, normals, lists->fits, local->queries, q, out, out_anchors, sharing,
                             left);
    if (std::ranges::any_of(left, [](char l) { return l != 0; })) {
      // Their k-long rows are built on the gathered points in their original order (the
      // canonical tie rule): the positions and normals go back to it (the fits read nothing
      // else but the rows), and the sharing lists, no longer read, make room for the rows.
      std::vector<char> has_normal(local->positions.size(), 0);
      for (std::size_t s = 0; s < order.size(); ++s) has_normal[order[s]] = lists->normals.counts[s] > 0;
      std::vector<Index> own_queries;
      std::vector<std::size_t> own_rows;
      for (std::size_t r = 0; r < left.size(); ++r)
        if (left[r]) {
          own_rows.push_back(r);
          own_queries.push_back(order[local->queries[r]]);
        }
      *lists = FinishLists{};
      permute_in_place(local->positions, row_of);
      permute_in_place(normals, row_of);
      const std::optional<OwnFitRows> own = own_fit_rows(part.box, halo, *local, own_queries, has_normal, q);
      if (!own) {
        account(needed);
        continue;
      }
      const std::vector<Vec3> named_normals = normals_of_queries(local->positions, own->normals, own->named, q);
      for (std::size_t r = 0; r < own->named.size(); ++r) normals[own->named[r]] = named_normals[r];
      std::vector<Vec3> own_out(own_queries.size()), own_anchors;
      if (!out_anchors.empty())
        for (const std::size_t r : own_rows) own_anchors.push_back(out_anchors[r]);
      project_rows_to_quadrics(local->positions, normals, own->fits, own_queries, q, own_out, own_anchors);
      for (std::size_t r = 0; r < own_rows.size(); ++r) out[own_rows[r]] = own_out[r];
    }
    if (!whole)
      for (std::size_t i = 0; i < part.rows.size(); ++i) result[part.rows[i]] = part_result[i];
    largest_local_ = std::max<std::uint64_t>(largest_local_, local->positions.size());
    account(needed);
    return true;
  }
}

bool Run::run_finish(OutOfCoreReport& report) {
  // The passes of finish_with_quadrics after the last step, each from the last one's
  // positions into the other buffer and committed like a step. False when stopped
  // (OutOfCoreOptions::stop_after_finish_passes).
  if (!params_.finish) return true;
  const QuadricProjectionParams& q = *params_.finish;
  const bool place = params_.placement == Placement::AlongNormal;
  int pass = static_cast<int>(state_[kFinishPasses]);
  report.finish_passes = pass;
  if (pass >= q.passes) return true;
  const auto t0 = Clock::now();
  // The flow's lists stay on file for the attributes; their memory goes to the wider halos.
  cache_.assign(tiles_.size(), {});
  cache_bytes_ = 0;
  const std::uint64_t writes = tiles_to_write();
  std::vector<Vec3> result, anchors;
  int passes_here = 0;
  for (; pass < q.passes; ++pass) {
    if (pass == 0 && ranks_->rank() == 0) file().dataset(kStopLambda).write_rows(0, 1, &stop_lambda_);
    // The halos are found around the tiles' bounds in the positions the pass starts from.
    neighbor_source_ = current_source();
    measure_bounds();
    h5::Dataset target = file().dataset(positions_buffer(target_buffer()));
    const QuadricProjectionParams pass_params = params_of_pass(q, pass);
    for (std::size_t t = first_tile_; t < end_tile_; ++t) {
      const std::uint64_t rows = tiles_.rows(t);
      if (rows == 0) continue;
      // The last pass places the tile's input points (SmoothParams::placement).
      if (place && pass + 1 == q.passes) {
        anchors.resize(rows);
        file().dataset(layout::positions).read_rows(tiles_.offsets[t], rows, anchors.data()->data());
      } else {
        anchors.clear();
      }
      finish_tile(t, pass_params, anchors, result);
      target.write_rows(tiles_.offsets[t], rows, result.data()->data(), h5::Transfer::Collective);
      progress("finish", t + 1 - first_tile_, end_tile_ - first_tile_);
    }
    // Collective writes: as many per rank as the rank with the most tiles.
    for (std::uint64_t w = my_tiles(); w < writes; ++w) target.write_rows<double>(0, 0, nullptr, h5::Transfer::Collective);
    state_[kStepBuffer] = target_code(false);
    state_[kFinishPasses] = pass + 1;
    commit_state();
    report.finish_passes = pass + 1;
    ++passes_here;
    if (options_.stop_after_finish_passes >= 0 && passes_here >= options_.stop_after_finish_passes) {
      report.seconds_finish += seconds_since(t0);
      return false;
    }
  }
  report.seconds_finish += seconds_since(t0);
  return true;
}

// ---- attributes and the end ---------------------------------------------------------------------

std::size_t Run::write_attributes(double lambda) {
  const std::string source_path = current_source();
  const h5::Dataset source = file().dataset(source_path);
  // compute_attributes orients normals away from the centre of the bounding box.
  // Each rank bounds its own rows; the box of the cloud is the maximum over the ranks of
  // (-min, max).
  Eigen::AlignedBox3d box;
  std::vector<Vec3> block;
  for (std::uint64_t first = my_first_row(); first < my_end_row(); first += kScanBlock) {
    const std::uint64_t count = std::min(kScanBlock, my_end_row() - first);
    block.resize(count);
    source.read_rows(first, count, block.data()->data());
    for (const Vec3& p : block) box.extend(p);
  }
  if (ranks_->size() > 1) {
    std::array<double, 6> extent = {-box.min().x(), -box.min().y(), -box.min().z(),
                                    box.max().x(),  box.max().y(),  box.max().z()};
    ranks_->max(extent);
    box = Eigen::AlignedBox3d(Vec3(-extent[0], -extent[1], -extent[2]), Vec3(extent[3], extent[4], extent[5]));
  }
  const std::string a = layout::run_attributes;
  h5::Dataset normal = file().dataset(a + "/normal"), d1 = file().dataset(a + "/d1"), d2 = file().dataset(a + "/d2");
  h5::Dataset k1 = file().dataset(a + "/k1"), k2 = file().dataset(a + "/k2");
  h5::Dataset mean = file().dataset(a + "/mean_curvature"), lap = file().dataset(a + "/laplacian_norm");
  h5::Dataset feature = file().dataset(a + "/feature_class");
  std::vector<Vec3> local, vn, vd1, vd2;
  std::vector<double> vk1, vk2, vmean, vlap;
  std::vector<std::uint8_t> vfeature;
  std::size_t degenerate = 0;
  const Vec3 centre = box.center();
  const std::uint64_t writes = tiles_to_write();
  constexpr h5::Transfer together = h5::Transfer::Collective;
  for (std::size_t t = first_tile_; t < end_tile_; ++t) {
    const std::uint64_t rows = tiles_.rows(t), begin = tiles_.offsets[t];
    if (rows == 0) continue;
    const std::shared_ptr<const TileNeighbors> lists = neighbors_of(t);
    const TileNeighbors& nb = *lists;
    const bool cached = caching_ && cache_[t] == lists;
    read_tile_positions(t, nb, source, local, vn);  // vn: the rows in row order, until it is written below
    // compute_attributes of the tile's rows (the first of its lists; the halo only their
    // neighbours), the normals oriented away from the centre of the whole cloud's box.
    const PointAttributes pa = compute_attributes(local, NeighborhoodsView(nb.local).rows(0, rows), centre,
                                                  params_.flow, lambda);
    degenerate += pa.degenerate;
    // Back from the lists' order to row order.
    nb.to_rows(pa.normal, vn, rows);
    nb.to_rows(pa.d1, vd1, rows);
    nb.to_rows(pa.d2, vd2, rows);
    nb.to_rows(pa.k1, vk1, rows);
    nb.to_rows(pa.k2, vk2, rows);
    nb.to_rows(pa.mean_curvature, vmean, rows);
    nb.to_rows(pa.laplacian_norm, vlap, rows);
    nb.to_rows(pa.feature, vfeature, rows);
    normal.write_rows(begin, rows, vn.data()->data(), together);
    d1.write_rows(begin, rows, vd1.data()->data(), together);
    d2.write_rows(begin, rows, vd2.data()->data(), together);
    k1.write_rows(begin, rows, vk1.data(), together);
    k2.write_rows(begin, rows, vk2.data(), together);
    mean.write_rows(begin, rows, vmean.data(), together);
    lap.write_rows(begin, rows, vlap.data(), together);
    feature.write_rows(begin, rows, vfeature.data(), together);
    account(bytes(local) + pa.normal.size() * (9 * sizeof(double) + 4 * sizeof(double) + 1) + 3 * bytes(vn) +
            4 * bytes(vk1) +
            bytes(vfeature) + (cached ? 0 : nb.bytes()));
    // The attributes are the last pass over the lists: the tile's halo rows (read for it, or
    // kept since the steps) are not needed again, so that the pass holds those of one tile at
    // a time rather than gathering every tile's.
    halo_bytes_ -= bytes(halo_rows_[t]);
    std::vector<std::uint64_t>().swap(halo_rows_[t]);
    progress("attributes", t + 1 - first_tile_, end_tile_ - first_tile_);
  }
  for (std::uint64_t w = my_tiles(); w < writes; ++w) {
    for (h5::Dataset* d : {&normal, &d1, &d2, &k1, &k2, &mean, &lap}) d->write_rows<double>(0, 0, nullptr, together);
    feature.write_rows<std::uint8_t>(0, 0, nullptr, together);
  }
  return static_cast<std::size_t>(ranks_->sum(degenerate));
}

void Run::finish(std::size_t attributes_degenerate, double lambda) {
  // Rank 0 alone from here (release()): attributes are metadata.
  if (options_.attributes) {
    file().set_attribute(layout::run_attributes, "degenerate", static_cast<std::int64_t>(attributes_degenerate));
    file().set_attribute(layout::run_attributes, "lambda", lambda);
  }
  file().set_attribute(layout::run, "result_positions", current_source());
  file().set_attribute(layout::run, "eps", eps_);
  state_[kFinished] = 1;
  commit_state();
  file_.reset();
  std::error_code ec;
  fs::rename(partial_name(output_), output_, ec);
  if (ec) throw io::IoError(output_.string() + ": cannot rename the finished run into place: " + ec.message());
}

}  // namespace pointfair::tiles::detail
