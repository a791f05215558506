#include "run_folder.hpp"

#include <string>
#include <system_error>

#include "pointfair/io/point_table.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"

namespace pointfair::cli {

namespace fs = std::filesystem;

namespace {

void remove_quietly(const fs::path& p) {
  std::error_code ec;
  fs::remove(p, ec);
}

}  // namespace

fs::path run_folder_of(const fs::path& output) {
  std::string name = ".";
  name += output.filename().string();
  name += ".pointfair-run";
  return output.parent_path() / name;
}

std::unique_ptr<io::FolderLock> open_run_folder(const fs::path& folder, bool resume, bool& existed) {
  std::error_code ec;
  const bool made = fs::create_directory(folder, ec);
  if (ec) throw io::IoError(folder.string() + ": cannot create the run's folder: " + ec.message());
  existed = !made;
  if (!made) {
    const auto status = fs::symlink_status(folder, ec);
    if (!fs::is_directory(status))
      throw io::IoError(folder.string() + ": exists and is not a run's folder: it is left alone; remove or rename it");
    if (!resume)
      throw io::IoError(folder.string() +
                        ": an interrupted run is in the way: pass --resume to continue it, or remove the folder");
  }
  auto lock = std::make_unique<io::FolderLock>(folder);
  if (!made) {
    for (const auto& entry : fs::directory_iterator(folder, ec)) {
      const std::string name = entry.path().filename().string();
      if (name != "input.h5" && name != "run.h5" && name != "run.h5.partial" && name != "run.h5.partial.coarse" &&
          !name.starts_with("."))
        throw io::IoError(folder.string() + ": holds files this tool did not make (" + name +
                          "): it is left alone; remove or rename it");
    }
  }
  return lock;
}

void remove_run_folder(const fs::path& folder) {
  tiles::remove_coarse_folder(folder / "run.h5");
  for (const char* name : {"input.h5", "run.h5", "run.h5.partial"}) remove_quietly(folder / name);
  remove_quietly(folder);  // only when empty: a temporary still being removed keeps it
}

}  // namespace pointfair::cli
