#include "laz/chunk_table.hpp"

#include <cstring>

#include "file_reader.hpp"
#include "laz/arithmetic_coder.hpp"
#include "laz/chunk_bytes.hpp"
#include "laz/integer_coder.hpp"

namespace pointfair::io::laz {

std::optional<std::vector<ChunkEntry>> read_chunk_table(const std::filesystem::path& file, std::uint64_t offset,
                                                        bool variable_chunk_size) {
  detail::FileReader reader(file);
  if (offset > reader.size() || reader.size() - offset < 8) return std::nullopt;
  reader.skip(offset);
  ChunkBytes bytes(reader, offset);
  bytes.set_limit(reader.size());
  try {
    std::uint8_t head[8];
    bytes.get(head, 8);
    std::uint32_t version, count;
    std::memcpy(&version, head, 4);
    std::memcpy(&count, head + 4, 4);
    if (version != 0) return std::nullopt;
    // Each entry takes at least a bit: a count beyond 8 per remaining byte is corrupt.
    if (count > 8 * (reader.size() - offset)) return std::nullopt;
    std::vector<ChunkEntry> chunks(count);
    if (count == 0) return chunks;
    ArithmeticDecoder decoder(bytes);
    decoder.start();
    IntegerCoder ic(32, 2);
    for (std::uint32_t i = 0; i < count; ++i) {
      const ChunkEntry previous = i > 0 ? chunks[i - 1] : ChunkEntry{};
      if (variable_chunk_size) {
        chunks[i].points = static_cast<std::uint32_t>(ic.decompress(decoder, static_cast<std::int32_t>(previous.points), 0));
      }
      chunks[i].bytes = static_cast<std::uint32_t>(ic.decompress(decoder, static_cast<std::int32_t>(previous.bytes), 1));
    }
    return chunks;
  } catch (const ChunkOverrun&) {
    return std::nullopt;
  } catch (const CorruptCode&) {
    return std::nullopt;
  }
}

std::string encode_chunk_table(const std::vector<ChunkEntry>& chunks, bool variable_chunk_size) {
  std::vector<std::uint8_t> out(8, 0);
  const std::uint32_t version = 0, count = static_cast<std::uint32_t>(chunks.size());
  std::memcpy(out.data(), &version, 4);
  std::memcpy(out.data() + 4, &count, 4);
  if (!chunks.empty()) {
    ArithmeticEncoder encoder(out);
    IntegerCoder ic(32, 2);
    for (std::size_t i = 0; i < chunks.size(); ++i) {
      const ChunkEntry previous = i > 0 ? chunks[i - 1] : ChunkEntry{};
      if (variable_chunk_size) {
        ic.compress(encoder, static_cast<std::int32_t>(previous.points), static_cast<std::int32_t>(chunks[i].points), 0);
      }
      ic.compress(encoder, static_cast<std::int32_t>(previous.bytes), static_cast<std::int32_t>(chunks[i].bytes), 1);
    }
    encoder.finish();
  }
  return std::string(out.begin(), out.end());
}

}  // namespace pointfair::io::laz
