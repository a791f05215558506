#include "halo_scratch.hpp"

#include <cassert>
#include <algorithm>
#include <limits>

#include "pointfair/io/point_table.hpp"

namespace pointfair::tiles {

HaloScratch::HaloScratch(const std::filesystem::path& directory, std::string name,
                         std::span<const std::vector<std::uint64_t>> halo_rows, std::span<const std::uint64_t> offsets,
                         std::size_t first_tile, std::size_t end_tile, const OrderOf& order_of)
    : file_(directory, std::move(name)), first_tile_(first_tile) {
  // Our own invariants (the run's tiles and halos), checked in debug builds.
  assert(first_tile <= end_tile && end_tile < offsets.size() && end_tile <= halo_rows.size());
  const std::size_t tiles = end_tile - first_tile;
  halo_begin_.assign(tiles + 1, 0);
  for (std::size_t i = 0; i < tiles; ++i) halo_begin_[i + 1] = halo_begin_[i] + halo_rows[first_tile + i].size();
  total_ = halo_begin_.back();

  // Each tile's halo, cut where the owning tile changes (the rows ascend, so each owner's rows
  // are one piece), and the pieces grouped by owner.
  struct Piece {
    std::size_t owner = 0;
    std::uint64_t at = 0;          // first row in the buffer
    const std::uint64_t* rows = nullptr;
    std::uint64_t count = 0;
  };
  std::vector<Piece> pieces;
  [[maybe_unused]] const std::uint64_t lowest = offsets[first_tile], end = offsets[end_tile];
  for (std::size_t i = 0; i < tiles; ++i) {
    const std::vector<std::uint64_t>& halo = halo_rows[first_tile + i];
    for (std::size_t j = 0; j < halo.size(); ++j)
      assert(halo[j] >= lowest && halo[j] < end && (j == 0 || halo[j] > halo[j - 1]));
    for (std::size_t j = 0; j < halo.size();) {
      const std::uint64_t g = halo[j];
      const std::size_t owner =
          static_cast<std::size_t>(std::upper_bound(offsets.begin(), offsets.end(), g) - offsets.begin()) - 1;
      std::size_t k = j + 1;
      while (k < halo.size() && halo[k] < offsets[owner + 1]) ++k;
      pieces.push_back({owner, halo_begin_[i] + j, halo.data() + j, k - j});
      j = k;
    }
  }
  std::stable_sort(pieces.begin(), pieces.end(), [](const Piece& a, const Piece& b) { return a.owner < b.owner; });
  runs_begin_.assign(tiles + 1, 0);
  runs_.reserve(pieces.size());
  picks_.reserve(total_);
  for (const Piece& p : pieces) {
    ++runs_begin_[p.owner - first_tile + 1];
    runs_.push_back({p.at, picks_.size(), p.count});
    for (std::uint64_t r = 0; r < p.count; ++r) picks_.push_back(static_cast<Index>(p.rows[r] - offsets[p.owner]));
  }
  for (std::size_t i = 0; i < tiles; ++i) runs_begin_[i + 1] += runs_begin_[i];
  // Picks as indices into the order write() is given each tile's points in.
  if (order_of) {
    std::vector<Index> slot_of;
    for (std::size_t i = 0; i < tiles; ++i) {
      if (runs_begin_[i] == runs_begin_[i + 1]) continue;
      const std::size_t u = first_tile + i;
      const std::vector<Index> order = order_of(u);
      if (order.empty()) continue;
      const std::uint64_t rows = offsets[u + 1] - offsets[u];
      assert(order.size() == rows);
      slot_of.assign(rows, std::numeric_limits<Index>::max());
      for (std::size_t s = 0; s < rows; ++s) {
        assert(order[s] < rows && slot_of[order[s]] == std::numeric_limits<Index>::max());  // a permutation
        slot_of[order[s]] = static_cast<Index>(s);
      }
      for (std::uint64_t r = runs_begin_[i]; r < runs_begin_[i + 1]; ++r)
        for (std::uint64_t j = 0; j < runs_[r].count; ++j) picks_[runs_[r].first + j] = slot_of[picks_[runs_[r].first + j]];
    }
  }

  // Both buffers' room now, so that a full disk shows here rather than in a step.
  file_.reserve(2 * buffer_bytes());
}

std::uint64_t HaloScratch::bytes() const {
  return (halo_begin_.capacity() + runs_begin_.capacity()) * sizeof(std::uint64_t) + runs_.capacity() * sizeof(Run) +
         picks_.capacity() * sizeof(Index) + kStagingPoints * sizeof(Vec3);
}

void HaloScratch::read(int b, std::size_t t, Vec3* out) const {
  const std::size_t i = t - first_tile_;
  const std::uint64_t first = halo_begin_[i], count = halo_begin_[i + 1] - first;
  file_.read(out, count * sizeof(Vec3), static_cast<std::uint64_t>(b) * buffer_bytes() + first * sizeof(Vec3));
}

void HaloScratch::write(int b, std::size_t u, const Vec3* points) {
  const std::size_t i = u - first_tile_;
  for (std::uint64_t r = runs_begin_[i]; r < runs_begin_[i + 1]; ++r) {
    const Run& run = runs_[r];
    for (std::uint64_t done = 0; done < run.count;) {
      const std::uint64_t n = std::min<std::uint64_t>(run.count - done, kStagingPoints);
      staging_.resize(std::max<std::size_t>(staging_.size(), n));
      for (std::uint64_t j = 0; j < n; ++j) staging_[j] = points[picks_[run.first + done + j]];
      file_.write(staging_.data(), n * sizeof(Vec3),
                  static_cast<std::uint64_t>(b) * buffer_bytes() + (run.at + done) * sizeof(Vec3));
      done += n;
    }
  }
}

}  // namespace pointfair::tiles
