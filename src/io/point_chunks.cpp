#include "pointfair/io/point_chunks.hpp"

#include <algorithm>
#include <cassert>

namespace pointfair::io {

std::size_t PointChunkReader::read(PointTable& chunk, std::size_t max_points) {
  assert(max_points >= 1);
  chunk.positions.clear();
  chunk.position_type = schema_.position_type;
  bool same = chunk.attributes.size() == schema_.attributes.size();
  for (std::size_t a = 0; same && a < chunk.attributes.size(); ++a) {
    same = chunk.attributes[a].name == schema_.attributes[a].name &&
           chunk.attributes[a].type == schema_.attributes[a].type;
  }
  if (!same) chunk.attributes = schema_.attributes;
  for (Attribute& attribute : chunk.attributes) attribute.values.clear();
  const std::size_t got = append(chunk, max_points);
  points_read_ += got;
  return got;
}

std::uint64_t PointChunkReader::skip(std::uint64_t points) {
  std::uint64_t done = 0;
  if (const std::optional<std::uint64_t> total = count()) {
    points = std::min(points, *total - std::min(*total, points_read_));
    if (points == 0) return 0;
    // All but the last skipped point by seeking where the format can; that one is read, so
    // that when it is the file's last point, what follows the points is handled as usual.
    if (points > 1 && seek_over(points - 1)) {
      points_read_ += points - 1;
      done = points - 1;
    }
  }
  PointTable chunk = schema_;
  while (done < points) {
    const std::size_t got = read(chunk, static_cast<std::size_t>(std::min<std::uint64_t>(points - done, 1u << 16)));
    if (got == 0) break;
    done += got;
  }
  return done;
}

}  // namespace pointfair::io
