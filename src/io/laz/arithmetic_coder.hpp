#pragma once
// The range coder of LAZ (LASzip's variant of Amir Said's "FastAC": a 32-bit interval that
// is renormalised a byte at a time, adaptive bit and symbol models whose counts are halved
// when they grow too large, and raw bits written at equal probability). Encoder and decoder
// must agree on every constant here, or the stream cannot be read.
//
// Reference: A. Said, "Introduction to Arithmetic Coding - Theory and Practice", HP Labs
// HPL-2004-76 (2004), and the LAZ specification (LASzip, M. Isenburg, "LASzip: lossless
// compression of LiDAR data", PE&RS 79(2), 2013).
#include <cstdint>
#include <vector>

#include "laz/chunk_bytes.hpp"

namespace pointfair::io::laz {

/// Thrown when a coded stream starts with a value outside the decoder's interval, which no
/// encoder writes: the stream is corrupt. Caught, like ChunkOverrun, by the chunk reader.
struct CorruptCode {};

/// An adaptive model of one binary decision.
struct BitModel {
  BitModel() { reset(); }
  void reset();
  /// Recomputes the probability from the counts (every `update_cycle` coded bits).
  void update();

  std::uint32_t bit_0_count = 1, bit_count = 2;
  std::uint32_t bit_0_prob = 0;  // in units of 2^-13
  std::uint32_t bits_until_update = 4, update_cycle = 4;
};

/// An adaptive model of a symbol in [0, symbols), 2 <= symbols <= 2048.
struct SymbolModel {
  explicit SymbolModel(std::uint32_t symbols);
  void reset();
  /// Recomputes the cumulative distribution from the counts.
  void update();

  std::uint32_t symbols;
  std::uint32_t last_symbol;
  std::vector<std::uint32_t> distribution;  // cumulative, in units of 2^-15
  std::vector<std::uint32_t> symbol_count;
  std::uint32_t total_count = 0, update_cycle = 0, symbols_until_update = 0;
  /// For more than 16 symbols, the decoder's search starts from a table: entry t is the
  /// last symbol whose cumulative value lies below t << table_shift (the bisection then
  /// narrows between entries t and t + 1). Empty for 16 symbols or fewer.
  std::vector<std::uint32_t> decoder_table;
  unsigned table_shift = 0;
};

/// Decodes from `bytes` (which throw ChunkOverrun past their end). Throws CorruptCode when
/// the stream cannot have been written by an encoder.
class ArithmeticDecoder {
 public:
  explicit ArithmeticDecoder(ChunkBytes& bytes) : bytes_(bytes) {}
  /// Reads the first four bytes of the coded stream.
  void start();
  std::uint32_t decode_bit(BitModel& model);
  std::uint32_t decode_symbol(SymbolModel& model);
  /// `count` raw bits, 1 <= count <= 32.
  std::uint32_t read_bits(unsigned count);
  std::uint32_t read_int() { const std::uint32_t lower = read_short(); return (read_short() << 16) | lower; }

 private:
  std::uint32_t read_short();
  void renormalise();

  ChunkBytes& bytes_;
  std::uint32_t value_ = 0, length_ = 0;
};

/// Encodes into a byte vector (a chunk's, written to the file when it is complete).
class ArithmeticEncoder {
 public:
  explicit ArithmeticEncoder(std::vector<std::uint8_t>& out) : out_(out) {}
  void encode_bit(BitModel& model, std::uint32_t bit);
  void encode_symbol(SymbolModel& model, std::uint32_t symbol);
  void write_bits(unsigned count, std::uint32_t bits);
  void write_int(std::uint32_t value) { write_short(value & 0xffff); write_short(value >> 16); }
  /// Flushes the interval: the bytes the decoder reads after the last symbol.
  void finish();

 private:
  void write_short(std::uint32_t value);
  void propagate_carry();
  void renormalise();

  std::vector<std::uint8_t>& out_;
  std::size_t first_ = out_.size();  // the coded stream starts here in out_
  std::uint32_t base_ = 0, length_ = 0xffffffffu;
};

}  // namespace pointfair::io::laz
