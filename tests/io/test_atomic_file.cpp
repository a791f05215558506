#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "io_test_util.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/point_table.hpp"

namespace pointfair::io {
namespace {

namespace fs = std::filesystem;
using testing::expect_io_error;
using testing::read_file;
using testing::TempDir;
using testing::write_file;

TEST(AtomicFile, WritesTargetAndLeavesNoTemporary) {
  TempDir dir;
  const auto target = dir / "out.txt";
  write_file_atomically(target, [](FileSink& sink) {
    sink.write("hello ");
    sink.write("world", 5);
  });
  EXPECT_EQ(read_file(target), "hello world");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.txt"});
}

TEST(AtomicFile, ReplacesExistingTargetKeepingItsPermissions) {
  TempDir dir;
  const auto target = dir / "out.txt";
  write_file(target, "old");
  fs::permissions(target, fs::perms::owner_read | fs::perms::owner_write);
  write_file_atomically(target, [](FileSink& sink) { sink.write("new"); });
  EXPECT_EQ(read_file(target), "new");
  EXPECT_EQ(fs::status(target).permissions(), fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.txt"});
}

TEST(AtomicFile, ThrowingBodyLeavesNoTargetAndNoTemporary) {
  TempDir dir;
  const auto target = dir / "out.txt";
  EXPECT_THROW(write_file_atomically(target,
                                     [](FileSink& sink) {
                                       sink.write("partial");
                                       throw std::runtime_error("stop");
                                     }),
               std::runtime_error);
  EXPECT_TRUE(dir.entries().empty());
}

TEST(AtomicFile, FailedWriteLeavesExistingTargetUntouched) {
  TempDir dir;
  const auto target = dir / "out.txt";
  write_file(target, "precious");
  EXPECT_THROW(write_file_atomically(target,
                                     [&](FileSink& sink) {
                                       sink.write("replacement");
                                       throw IoError(target.string() + ": simulated failure");
                                     }),
               IoError);
  EXPECT_EQ(read_file(target), "precious");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.txt"});
}

TEST(AtomicFile, MissingDirectoryIsAnIoError) {
  TempDir dir;
  const auto target = dir / "no" / "such" / "out.txt";
  expect_io_error([&] { write_file_atomically(target, [](FileSink&) {}); }, target,
                  "cannot create file: No such file or directory");
}

TEST(AtomicFile, TargetThatIsADirectoryIsAnIoError) {
  TempDir dir;
  fs::create_directory(dir / "sub");
  const auto target = dir / "sub";
  expect_io_error([&] { write_file_atomically(target, [](FileSink&) {}); }, target,
                  "Is a directory");
}

// /dev/full accepts opens and fails every write with ENOSPC, like a full disk.
TEST(AtomicFile, SinkReportsDiskFull) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "/dev/full is not available";
  const fs::path name = "/dev/full";
  {
    std::FILE* file = std::fopen("/dev/full", "wb");
    ASSERT_NE(file, nullptr);
    FileSink sink(file, name);
    sink.write("small");  // fits in the stdio buffer; the error surfaces on flush
    expect_io_error([&] { sink.flush(); }, name, "write failed: No space left on device");
    std::fclose(file);
  }
  {
    std::FILE* file = std::fopen("/dev/full", "wb");
    ASSERT_NE(file, nullptr);
    FileSink sink(file, name);
    const std::string large(std::size_t{1} << 20, 'x');
    expect_io_error([&] { sink.write(large); }, name, "write failed: No space left on device");
    std::fclose(file);
  }
}

TEST(RequireDistinct, SameFileUnderAnyNameIsRefused) {
  TempDir dir;
  const auto input = dir / "in.ply";
  write_file(input, "data");
  expect_io_error([&] { require_distinct(input, input); }, input,
                  "output would overwrite the input");
  const auto spelled = dir / "." / ".." / dir.path().filename() / "in.ply";
  expect_io_error([&] { require_distinct(input, spelled); }, spelled,
                  "output would overwrite the input");
  const auto link = dir / "link.ply";
  fs::create_symlink(input, link);
  expect_io_error([&] { require_distinct(input, link); }, link, "output would overwrite the input");
}

TEST(RequireDistinct, DifferentFilesAreAccepted) {
  TempDir dir;
  const auto input = dir / "in.ply";
  const auto output = dir / "out.ply";
  write_file(input, "data");
  EXPECT_NO_THROW(require_distinct(input, output));
  write_file(output, "other");
  EXPECT_NO_THROW(require_distinct(input, output));
  EXPECT_NO_THROW(require_distinct(dir / "missing.ply", output));
}

TEST(RequireDistinct, SameMissingPathIsRefused) {
  TempDir dir;
  const auto missing = dir / "gone.ply";
  expect_io_error([&] { require_distinct(missing, dir / "sub" / ".." / "gone.ply"); }, "gone.ply",
                  "output would overwrite the input");
}

}  // namespace
}  // namespace pointfair::io
