#pragma once
// The folder of an out-of-core run that reads or writes a point file: ".<OUT's name>.pointfair-run"
// beside OUT, holding the imported input ("input.h5") and the run ("run.h5",
// "run.h5.partial", and the coarse level's folder "run.h5.partial.coarse"). The run's own files live in a folder the run made, so that they can
// never be a user's file; the folder is locked while the run works and removed when it ends,
// but for an interrupted run, which a resume continues.
#include <filesystem>
#include <memory>

#include "pointfair/io/file_lock.hpp"

namespace pointfair::cli {

/// The run's folder of a run writing `output`: ".<name>.pointfair-run" beside it.
std::filesystem::path run_folder_of(const std::filesystem::path& output);

/// Makes or (with `resume`) reopens the run's folder `folder`, and locks it. `existed`: it was
/// there before (an interrupted run's, which the caller must never lose). Throws IoError naming
/// the folder when it cannot be made, is not a folder, holds an interrupted run and `resume` is
/// false, or holds files the run does not make.
std::unique_ptr<io::FolderLock> open_run_folder(const std::filesystem::path& folder, bool resume, bool& existed);

/// Removes the run's files from `folder` (only the names a run makes) and the folder when it is
/// then empty. Never throws.
void remove_run_folder(const std::filesystem::path& folder);

}  // namespace pointfair::cli
