#pragma once
// A folder of point files read as one cloud: real scans arrive cut into tiles, one file each,
// and a run smooths them together so that neighbourhoods reach across the files' borders.
// The cloud is the files' points concatenated in the order of point_files_in.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "pointfair/io/point_chunks.hpp"
#include "pointfair/io/point_table.hpp"

namespace pointfair::io {

/// True for a file a folder run takes: a regular file (or a link to one) directly in the
/// folder, not hidden (no leading '.', the name of the temporaries our writers make), with
/// the extension .las, .laz, .ply or .xyz (case-insensitive). The other text extensions
/// (.txt, .csv, .pts, .asc) are left out: a folder of tiles often holds notes under them.
bool is_folder_point_file(const std::filesystem::directory_entry& entry);

/// The point files of `folder` (is_folder_point_file), sorted by file name in byte order;
/// files of other kinds and subfolders are ignored. Throws IoError "<folder>: ..." when it
/// cannot be listed, is not a folder, or holds no point file.
std::vector<std::filesystem::path> point_files_in(const std::filesystem::path& folder);

/// A reader of the positions of `files` one after another (no attributes: the files may have
/// different ones; Float64 positions). count() is the sum of the files' declared counts, or
/// nullopt when one of them declares none (text). Errors name the file they come from, as its
/// own reader's do. `files` must not be empty.
std::unique_ptr<PointChunkReader> open_folder_reader(const std::vector<std::filesystem::path>& files,
                                                     const ReadOptions& options = {});

/// io::file_digest over the files' names and contents in order: tells a folder whose files
/// changed (or were added, removed or renamed) from the one a run started from.
std::string folder_digest(const std::vector<std::filesystem::path>& files);

}  // namespace pointfair::io
