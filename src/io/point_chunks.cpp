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
  if (const std::optional<std::uint64_t> total = count()) {
    points = std::min(points, *total - std::min(*total, points_read_));
    if (points == 0) return 0;
    if (seek_over(points)) {
      points_read_ += points;
      return points;
    }
  }
  PointTable chunk = schema_;
  std::uint64_t done = 0;
  while (done < points) {
    const std::size_t got = read(chunk, static_cast<std::size_t>(std::min<std::uint64_t>(points - done, 1u << 16)));
    if (got == 0) break;
    done += got;
  }
  return done;
}

}  // namespace pointfair::io
