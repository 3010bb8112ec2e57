#include "cairn/linear/spill_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <vector>

namespace cairn {
namespace {

std::string DefaultDir() {
  const char* tmpdir = std::getenv("TMPDIR");
  return tmpdir && *tmpdir ? tmpdir : "/var/tmp";
}

// O_TMPFILE where the file system has it; else a named file, unlinked at
// once: either way nothing is left behind, whatever ends the process.
int OpenUnnamed(const std::string& dir) {
#ifdef O_TMPFILE
  const int fd = open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd >= 0) return fd;
#endif
  std::string name = dir + "/.cairn-spill-XXXXXX";
  std::vector<char> path(name.begin(), name.end());
  path.push_back('\0');
  const int named = mkostemp(path.data(), O_CLOEXEC);
  if (named >= 0) unlink(path.data());
  return named;
}

}  // namespace

SpillFile::SpillFile(const std::string& dir) : dir_(dir.empty() ? DefaultDir() : dir) {
  fd_ = OpenUnnamed(dir_);
}

SpillFile::~SpillFile() {
  if (fd_ >= 0) close(fd_);
}

bool SpillFile::Write(std::size_t offset, const double* data, std::size_t count) {
  const char* p = reinterpret_cast<const char*>(data);
  std::size_t left = count * sizeof(double);
  while (left > 0) {
    const ssize_t n = pwrite(fd_, p, left, static_cast<off_t>(offset));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n, offset += static_cast<std::size_t>(n), left -= static_cast<std::size_t>(n);
  }
  return true;
}

bool SpillFile::Read(std::size_t offset, double* data, std::size_t count) const {
  char* p = reinterpret_cast<char*>(data);
  std::size_t left = count * sizeof(double);
  while (left > 0) {
    const ssize_t n = pread(fd_, p, left, static_cast<off_t>(offset));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n, offset += static_cast<std::size_t>(n), left -= static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace cairn
