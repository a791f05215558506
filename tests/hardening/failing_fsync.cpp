// Preloaded (LD_PRELOAD) into the pointfair executable by the hostile-environment tests: fsync
// fails with EIO from its Nth call on (counting from 0), N from the environment variable
// POINTFAIR_TEST_FSYNC_FAILS_FROM, as on a disk that cannot write back what the program
// wrote. Without the variable every call goes to the C library's fsync.
#include <dlfcn.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>

extern "C" int fsync(int fd) {
  static std::atomic<long> calls{0};
  const char* from = std::getenv("POINTFAIR_TEST_FSYNC_FAILS_FROM");
  if (from != nullptr && calls++ >= std::atol(from)) {
    errno = EIO;
    return -1;
  }
  using Fsync = int (*)(int);
  static const auto real = reinterpret_cast<Fsync>(dlsym(RTLD_NEXT, "fsync"));
  return real(fd);
}
