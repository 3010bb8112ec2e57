// Room on disk for numbers that need not stay in memory: an unnamed
// temporary file, gone when closed or when the process dies, holding arrays
// of doubles at offsets the caller chooses. The two-halves factorisation
// parks one half's factor there while it works on the other
// (domain_cholesky.cpp), so that the solve's memory stays proportional to
// the graph. Internal to backend/.
#pragma once

#include <cstddef>
#include <string>

namespace cairn {

class SpillFile {
 public:
  // In `dir`; when empty, $TMPDIR, else /var/tmp (on disk where /tmp may be
  // held in memory, which would defeat the purpose). ok() says whether it
  // could be made.
  explicit SpillFile(const std::string& dir = "");
  ~SpillFile();
  SpillFile(const SpillFile&) = delete;
  SpillFile& operator=(const SpillFile&) = delete;

  bool ok() const { return fd_ >= 0; }
  const std::string& dir() const { return dir_; }

  // `count` doubles at byte `offset`; false on any failure (a full disk).
  bool Write(std::size_t offset, const double* data, std::size_t count);
  bool Read(std::size_t offset, double* data, std::size_t count) const;

 private:
  int fd_ = -1;
  std::string dir_;
};

}  // namespace cairn
