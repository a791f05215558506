#include "pointfair/io/point_folder.hpp"

#include <algorithm>
#include <cctype>
#include <optional>
#include <system_error>
#include <utility>

#include "pointfair/io/file_lock.hpp"
#include "pointfair/io/point_file.hpp"

namespace pointfair::io {

namespace fs = std::filesystem;

namespace {

class FolderReader final : public PointChunkReader {
 public:
  FolderReader(std::vector<fs::path> files, const ReadOptions& options)
      : PointChunkReader(files.front().parent_path()), files_(std::move(files)), options_(options) {
    schema_.position_type = ScalarType::Float64;
    std::uint64_t total = 0;
    bool declared = true;
    for (const fs::path& file : files_) {
      const auto count = open_point_reader(file)->count();  // its warnings come when it is read
      declared = declared && count.has_value();
      total += count.value_or(0);
    }
    if (declared) count_ = total;
  }

  std::optional<std::uint64_t> count() const override { return count_; }

 protected:
  std::size_t append(PointTable& chunk, std::size_t max_points) override {
    std::size_t got = 0;
    while (got < max_points) {
      if (!current_) {
        if (next_ == files_.size()) break;
        current_ = open_point_reader(files_[next_++], options_);
      }
      const std::size_t n = current_->read(part_, max_points - got);
      if (n == 0) {
        current_.reset();
        continue;
      }
      chunk.positions.insert(chunk.positions.end(), part_.positions.begin(), part_.positions.end());
      got += n;
    }
    return got;
  }

 private:
  std::vector<fs::path> files_;
  ReadOptions options_;
  std::optional<std::uint64_t> count_;
  std::size_t next_ = 0;
  std::unique_ptr<PointChunkReader> current_;
  PointTable part_;
};

}  // namespace

bool is_folder_point_file(const fs::directory_entry& entry) {
  const std::string name = entry.path().filename().string();
  if (name.empty() || name.front() == '.') return false;
  std::error_code ec;
  if (!entry.is_regular_file(ec)) return false;
  std::string e = entry.path().extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e == ".las" || e == ".laz" || e == ".ply" || e == ".xyz";
}

std::vector<fs::path> point_files_in(const fs::path& folder) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw IoError(folder.string() + ": is not a folder");
  std::vector<fs::path> files;
  fs::directory_iterator it(folder, ec);
  if (ec) throw IoError(folder.string() + ": cannot list the folder: " + ec.message());
  for (; it != fs::directory_iterator(); it.increment(ec)) {
    if (ec) throw IoError(folder.string() + ": cannot list the folder: " + ec.message());
    if (is_folder_point_file(*it)) files.push_back(it->path());
  }
  if (files.empty())
    throw IoError(folder.string() + ": holds no point file (.las, .laz, .ply or .xyz directly in the folder)");
  // Byte order of the names: std::string compares as unsigned bytes.
  std::sort(files.begin(), files.end(),
            [](const fs::path& a, const fs::path& b) { return a.filename().string() < b.filename().string(); });
  return files;
}

std::unique_ptr<PointChunkReader> open_folder_reader(const std::vector<fs::path>& files, const ReadOptions& options) {
  if (files.empty()) throw IoError("a folder reader needs at least one file");
  return std::make_unique<FolderReader>(files, options);
}

std::string folder_digest(const std::vector<fs::path>& files) {
  std::uint64_t state = kDigestSeed;
  for (const fs::path& file : files) {
    const std::string entry = file.filename().string() + '\0' + file_digest(file) + '\0';
    state = digest_update(state, entry.data(), entry.size());
  }
  return digest_text(state);
}

}  // namespace pointfair::io
