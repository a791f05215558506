#pragma once
// The chunk table of a LAZ file: where each chunk of compressed points starts and how many
// points it holds. The point data starts with the table's file offset (int64; -1: the
// offset is in the file's last 8 bytes); the table is a version (0), a chunk count, then
// per chunk its point count (only with variable chunk sizes) and its byte count, each coded
// with the integer compressor from the previous chunk's.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace pointfair::io::laz {

struct ChunkEntry {
  std::uint64_t points = 0;
  std::uint64_t bytes = 0;
};

/// The table at file offset `offset` of `file`; nullopt when it cannot be read (it lies
/// beyond the end of the file or its coded entries run past it).
std::optional<std::vector<ChunkEntry>> read_chunk_table(const std::filesystem::path& file, std::uint64_t offset,
                                                        bool variable_chunk_size);
/// The table's bytes, as read_chunk_table reads them.
std::string encode_chunk_table(const std::vector<ChunkEntry>& chunks, bool variable_chunk_size);

}  // namespace pointfair::io::laz
