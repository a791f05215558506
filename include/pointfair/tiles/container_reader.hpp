#pragma once
// The points of a container read a chunk at a time, in the input's point order (or the tile
// order), so that export writes a cloud larger than memory: a chunk of the input's order
// [b, b + m) is gathered from every tile's rows whose original index falls in it. Tiles whose
// rows ascend in original index (every container import_points writes) are read forward
// once; other tiles are scanned once per chunk.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

#include "pointfair/io/point_chunks.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/tiles/hdf5_file.hpp"

namespace pointfair::tiles {

struct ContainerReaderOptions {
  /// Chunks in the input's point order (true) or in the container's row (tile) order.
  bool original_order = true;
  /// With a smoothing run in the file: its final positions (IoError if it is unfinished).
  bool result_positions = true;
  /// Also read the run's per-point results (normals, curvatures, feature classes) of each
  /// chunk: run_attributes(). IoError if the file holds no finished run with attributes.
  bool run_attributes = false;
};

class ContainerChunkReader final : public io::PointChunkReader {
 public:
  /// Opens the container and checks its tile table and original indices (one pass over the
  /// indices). Throws IoError naming the file and dataset.
  ContainerChunkReader(const std::filesystem::path& file, const ContainerReaderOptions& options = {});
  ~ContainerChunkReader() override;

  std::optional<std::uint64_t> count() const override { return n_; }
  /// The run's results for the points of the last chunk (empty unless asked for).
  const PointAttributes& run_attributes() const { return run_; }
  /// Points per chunk for which a chunk (with its attributes and run results), the reader's
  /// scratch and a point writer's encoding block take about `budget` bytes (at least 1024).
  std::size_t chunk_points_for(std::uint64_t budget) const;

 protected:
  std::size_t append(io::PointTable& chunk, std::size_t max_points) override;

 private:
  struct Column;
  void read_range(std::uint64_t first, std::uint64_t count, std::uint64_t block_begin,
                  const std::uint64_t* originals, io::PointTable& chunk);

  ContainerReaderOptions options_;
  std::optional<h5::File> file_;
  std::uint64_t n_ = 0;
  std::vector<std::uint64_t> offsets_;
  std::vector<std::uint64_t> cursor_;  // per tile: first row not yet returned (sorted tiles)
  std::vector<char> sorted_;           // per tile: rows ascend in original index
  std::vector<Column> columns_;
  PointAttributes run_;
  std::vector<char> filled_;
  std::vector<std::uint64_t> index_;
  std::vector<double> scratch_;
};

}  // namespace pointfair::tiles
