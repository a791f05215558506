// A container's rows in and around a box (coarse_stages.hpp).
#include <algorithm>
#include <numeric>

#include "coarse_stages.hpp"

namespace pointfair::tiles::coarse {

namespace {

constexpr std::uint64_t kBlock = 1u << 15;

}  // namespace

std::uint64_t Gathered::bytes() const {
  std::uint64_t b = original.size() * (sizeof(std::uint64_t) + sizeof(std::int64_t));
  for (const auto& c : columns) b += c.size() * sizeof(Vec3);
  return b;
}

bool holds_all(const TileTable& tiles, const Box& box, double halo) {
  const Box all = cloud_bounds(tiles);
  for (std::size_t c = 0; c < 3; ++c)
    if (all[c] < box[c] - halo || all[c + 3] > box[c + 3] + halo) return false;
  return true;
}

Gathered gather_around(const h5::File& file, const TileTable& tiles, const Box& box, double halo,
                       std::size_t own, std::span<const Column> columns) {
  Box grown = box;
  for (std::size_t c = 0; c < 3; ++c) {
    grown[c] -= halo;
    grown[c + 3] += halo;
  }
  const h5::Dataset orig = file.dataset(layout::original_index);
  std::vector<h5::Dataset> sets;
  for (const Column& c : columns) sets.push_back(c.file->dataset(c.path));
  struct Entry {
    std::uint64_t original;
    std::int64_t tile_row;
    std::size_t at;  // index into the values gathered
  };
  std::vector<Entry> entries;
  std::vector<std::vector<Vec3>> values(columns.size());
  std::vector<std::vector<Vec3>> block(columns.size());
  std::vector<std::uint64_t> index;
  for (std::size_t u = 0; u < tiles.size(); ++u) {
    if (tiles.rows(u) == 0 || (u != own && !intersects(box, halo, tiles.bounds[u]))) continue;
    for (std::uint64_t first = tiles.offsets[u]; first < tiles.offsets[u + 1]; first += kBlock) {
      const std::uint64_t count = std::min(kBlock, tiles.offsets[u + 1] - first);
      for (std::size_t c = 0; c < sets.size(); ++c) {
        block[c].resize(count);
        sets[c].read_rows(first, count, block[c].data()->data());
      }
      index.resize(count);
      orig.read_rows(first, count, index.data());
      for (std::uint64_t r = 0; r < count; ++r) {
        const Vec3& p = block[0][r];
        if (!p.allFinite())
          columns[0].file->fail(columns[0].path, "row " + std::to_string(first + r) + " has a non-finite coordinate");
        bool inside = u == own;
        for (std::size_t c = 0; c < 3 && !inside; ++c) {
          const double v = p[static_cast<Eigen::Index>(c)];
          if (!(v >= grown[c] && v <= grown[c + 3])) break;
          inside = c == 2;
        }
        if (!inside) continue;
        entries.push_back({index[r], u == own ? static_cast<std::int64_t>(first + r - tiles.offsets[u]) : -1,
                           values[0].size()});
        for (std::size_t c = 0; c < sets.size(); ++c) values[c].push_back(block[c][r]);
      }
    }
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.original < b.original; });
  Gathered g;
  g.columns.resize(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c) {
    g.columns[c].resize(entries.size());
    for (std::size_t i = 0; i < entries.size(); ++i) g.columns[c][i] = values[c][entries[i].at];
  }
  g.original.resize(entries.size());
  g.tile_row.resize(entries.size());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    g.original[i] = entries[i].original;
    g.tile_row[i] = entries[i].tile_row;
  }
  return g;
}

}  // namespace pointfair::tiles::coarse
