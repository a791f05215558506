#include "pointfair/io/point_chunks.hpp"

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

}  // namespace pointfair::io
