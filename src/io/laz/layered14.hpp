#pragma once
// The layered codecs of LAZ for LAS 1.4's point formats 6-8 (item version 3: POINT14, RGB14,
// RGBNIR14, BYTE14). A chunk stores its first record raw, then each attribute group in its
// own arithmetic-coded layer: returns and XY, Z, classification, flags, intensity, scan angle,
// user data, point source id, GPS time, then RGB, NIR and one layer per extra byte. Every
// prediction is made from the previous point of the same scanner channel (four contexts).
//
// Reference: "LASzip for LAS 1.4 (native extension), Specification Document" (rapidlasso).
#include <cstdint>
#include <memory>
#include <vector>

namespace pointfair::io::laz {

/// Compresses or decompresses the records of one chunk (one direction per object).
class Layered14Codec {
 public:
  /// Records of point format 6, 7 or 8 followed by `extra_bytes` bytes.
  Layered14Codec(int point_format, std::size_t extra_bytes);
  ~Layered14Codec();
  Layered14Codec(const Layered14Codec&) = delete;
  Layered14Codec& operator=(const Layered14Codec&) = delete;

  /// Layers per chunk: 9 for the point, 1 for RGB, 1 for NIR, 1 per extra byte.
  std::size_t layer_count() const;

  /// Decoding: the chunk's first (raw) record, then the chunk's layers (empty: the layer's
  /// attributes never change in the chunk). Throws ChunkOverrun past a layer's end.
  void start_decoding(const std::uint8_t* record, std::vector<std::vector<std::uint8_t>> layers);
  void decode(std::uint8_t* record);

  /// Encoding: the chunk's first record (stored raw by the caller), then the others; then
  /// the layers (empty for one whose attributes never changed).
  void start_encoding(const std::uint8_t* record);
  void encode(const std::uint8_t* record);
  std::vector<std::vector<std::uint8_t>> finish_encoding();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace pointfair::io::laz
