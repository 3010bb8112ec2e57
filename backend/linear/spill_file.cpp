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

// O_TMPFILE where the file system has it: nothing is left behind, whatever
// ends the process. Else a named file, unlinked at once (only a kill
// between the two calls could leave it).
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

// The whole range through pwrite or pread, past interruptions and short
// counts; false on an error or at the file's end.
template <typename Call>
bool Whole(std::size_t bytes, std::size_t offset, Call call) {
  std::size_t done = 0;
  while (done < bytes) {
    const ssize_t n = call(done, bytes - done, static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

SpillFile::SpillFile(const std::string& dir) : dir_(dir.empty() ? DefaultDir() : dir) {
  fd_ = OpenUnnamed(dir_);
}

SpillFile::~SpillFile() {
  if (fd_ >= 0) close(fd_);
}

bool SpillFile::Write(std::size_t offset, const double* data, std::size_t count) {
  const char* bytes = reinterpret_cast<const char*>(data);
  return Whole(count * sizeof(double), offset, [&](std::size_t at, std::size_t n, off_t where) {
    return pwrite(fd_, bytes + at, n, where);
  });
}

bool SpillFile::Read(std::size_t offset, double* data, std::size_t count) const {
  char* bytes = reinterpret_cast<char*>(data);
  return Whole(count * sizeof(double), offset, [&](std::size_t at, std::size_t n, off_t where) {
    return pread(fd_, bytes + at, n, where);
  });
}

}  // namespace cairn
