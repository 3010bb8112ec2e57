#include "cairn/graph/output_files.h"

#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <ostream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <streambuf>
#include <string>

namespace cairn {

namespace {

[[noreturn]] void Fail(const std::string& path, const std::string& what, int err) {
  throw std::runtime_error(path + ": " + what + " (" + std::strerror(err) + ")");
}

// ---- Temporaries removed on SIGINT and SIGTERM -----------------------------
// A fixed table, so that the handler reads it without locks or allocation:
// a slot is claimed (kClaimed), its path copied, then published (kLive).

constexpr int kSlots = 64;
enum SlotState { kFree = 0, kClaimed = 1, kLive = 2 };
struct Slot {
  std::atomic<int> state{kFree};
  char path[PATH_MAX];
};
Slot g_slots[kSlots];
struct sigaction g_previous[2];  // SIGINT, SIGTERM
constexpr int kSignals[2] = {SIGINT, SIGTERM};

void RemoveTemporariesOnSignal(int sig, siginfo_t* info, void* context) {
  const int saved_errno = errno;
  for (Slot& s : g_slots)
    if (s.state.load(std::memory_order_acquire) == kLive) ::unlink(s.path);
  const struct sigaction& prev = g_previous[sig == SIGINT ? 0 : 1];
  if (prev.sa_flags & SA_SIGINFO) {
    if (prev.sa_sigaction) prev.sa_sigaction(sig, info, context);
  } else if (prev.sa_handler != SIG_DFL && prev.sa_handler != SIG_IGN) {
    prev.sa_handler(sig);
  } else {
    // Die of the signal, as without us: the parent sees how we ended.
    struct sigaction dfl {};
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    ::sigaction(sig, &dfl, nullptr);
    sigset_t only;
    sigemptyset(&only);
    sigaddset(&only, sig);
    ::pthread_sigmask(SIG_UNBLOCK, &only, nullptr);
    ::raise(sig);
  }
  errno = saved_errno;
}

// Once per process; a signal the process ignores stays ignored (nohup, a
// background job), and a handler already there is called after ours.
void InstallSignalHandlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int k = 0; k < 2; ++k) {
      struct sigaction current {};
      if (::sigaction(kSignals[k], nullptr, &current) != 0) continue;
      if (!(current.sa_flags & SA_SIGINFO) && current.sa_handler == SIG_IGN) continue;
      g_previous[k] = current;
      struct sigaction ours {};
      ours.sa_sigaction = RemoveTemporariesOnSignal;
      ours.sa_flags = SA_SIGINFO | SA_RESTART;
      sigemptyset(&ours.sa_mask);
      for (int s : kSignals) sigaddset(&ours.sa_mask, s);
      ::sigaction(kSignals[k], &ours, nullptr);
    }
  });
}

// Blocks SIGINT and SIGTERM for its lifetime: a temporary is created and
// registered with no signal in between.
class SignalsBlocked {
 public:
  SignalsBlocked() {
    sigset_t set;
    sigemptyset(&set);
    for (int s : kSignals) sigaddset(&set, s);
    ::pthread_sigmask(SIG_BLOCK, &set, &old_);
  }
  ~SignalsBlocked() { ::pthread_sigmask(SIG_SETMASK, &old_, nullptr); }

 private:
  sigset_t old_;
};

int Register(const std::string& path) {
  if (path.size() >= PATH_MAX) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = kFree;
    if (g_slots[i].state.compare_exchange_strong(expected, kClaimed)) {
      std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
      g_slots[i].state.store(kLive, std::memory_order_release);
      return i;
    }
  }
  return -1;  // more live temporaries than slots: this one is not cleaned on a signal
}

void Unregister(int slot) {
  if (slot >= 0) g_slots[slot].state.store(kFree, std::memory_order_release);
}

// ---- Names -----------------------------------------------------------------

std::mutex g_names_mutex;
std::function<std::string(int)> g_test_names;

std::string TemporaryName(const std::string& base, int attempt) {
  {
    std::lock_guard<std::mutex> lock(g_names_mutex);
    if (g_test_names) return g_test_names(attempt);
  }
  static constexpr char kChars[] =
      "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
  std::random_device random;  // the kernel's generator: not guessable from the pid or the time
  std::string name = "." + base + ".";
  for (int k = 0; k < 12; ++k) name += kChars[random() % (sizeof(kChars) - 1)];
  return name + ".tmp";
}

// ---- Where an output really goes -------------------------------------------

struct Target {
  std::string final_path;  // absolute, symlinks followed; may not exist yet
  std::string dir;         // its directory, absolute
  std::string base;        // its name in dir
  bool exists = false;
  bool in_place = false;  // not a regular file (a device, a FIFO, /proc/self/fd/N)
  struct stat st {};
};

void SplitPath(const std::string& p, std::string* dir, std::string* base) {
  const size_t slash = p.find_last_of('/');
  if (slash == std::string::npos) {
    *dir = ".";
    *base = p;
  } else {
    *dir = slash == 0 ? "/" : p.substr(0, slash);
    *base = p.substr(slash + 1);
  }
}

// Follows `path` link by link (the kernel resolves the directories) to the
// file that a plain open would write. Throws when its directory is missing.
Target Resolve(const std::string& path) {
  if (path.empty()) throw std::runtime_error("an output or input path is empty");
  Target t;
  std::string p = path;
  for (int hops = 0;; ++hops) {
    if (hops > 40) Fail(path, "cannot follow the symlinks", ELOOP);
    std::string dir, base;
    SplitPath(p, &dir, &base);
    if (base.empty() || base == "." || base == "..") Fail(path, "is a directory", EISDIR);
    char* real = ::realpath(dir.c_str(), nullptr);
    if (!real) Fail(path, "no directory " + dir + " to write in", errno);
    t.dir = real;
    std::free(real);
    t.base = base;
    t.final_path = (t.dir == "/" ? "" : t.dir) + "/" + base;
    struct stat link {};
    if (::lstat(t.final_path.c_str(), &link) != 0) {
      if (errno != ENOENT) Fail(path, "cannot examine " + t.final_path, errno);
      return t;
    }
    if (S_ISLNK(link.st_mode) && t.dir.rfind("/proc/", 0) != 0) {
      std::string to(PATH_MAX, '\0');
      const ssize_t n = ::readlink(t.final_path.c_str(), &to[0], to.size());
      if (n < 0) Fail(path, "cannot read the symlink " + t.final_path, errno);
      to.resize(n);
      p = to[0] == '/' ? to : t.dir + "/" + to;
      continue;
    }
    // /proc's links (/dev/stdout, /dev/fd/N) name open files, not paths.
    if (::stat(t.final_path.c_str(), &t.st) != 0) Fail(path, "cannot examine", errno);
    t.exists = true;
    t.in_place = S_ISLNK(link.st_mode) || !S_ISREG(t.st.st_mode);
    return t;
  }
}

// ---- Writing ---------------------------------------------------------------

bool WriteAll(int fd, const char* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    data += n;
    size -= static_cast<size_t>(n);
  }
  return true;
}

// An ostream's buffer onto a file descriptor; remembers the first error.
class FdBuffer : public std::streambuf {
 public:
  explicit FdBuffer(int fd) : fd_(fd) { setp(buffer_, buffer_ + sizeof(buffer_)); }
  int error() const { return error_; }

 protected:
  int_type overflow(int_type c) override {
    if (!Drain()) return traits_type::eof();
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(c);
      pbump(1);
    }
    return traits_type::not_eof(c);
  }
  int sync() override { return Drain() ? 0 : -1; }

 private:
  bool Drain() {
    if (error_) return false;
    if (!WriteAll(fd_, pbase(), static_cast<size_t>(pptr() - pbase()))) {
      error_ = errno ? errno : EIO;
      return false;
    }
    setp(buffer_, buffer_ + sizeof(buffer_));
    return true;
  }
  int fd_;
  int error_ = 0;
  char buffer_[1 << 16];
};

void SyncDirectory(const std::string& dir, const std::string& path) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) Fail(path, "cannot open its directory to sync it", errno);
  // Some file systems cannot sync a directory (EINVAL): nothing more to do there.
  if (::fsync(fd) != 0 && errno != EINVAL && errno != ENOTSUP) {
    const int err = errno;
    ::close(fd);
    Fail(path, "cannot sync its directory", err);
  }
  ::close(fd);
}

}  // namespace

void SetTemporaryNamesForTesting(std::function<std::string(int attempt)> names) {
  std::lock_guard<std::mutex> lock(g_names_mutex);
  g_test_names = std::move(names);
}

struct OutputSet::Output {
  std::string path;  // as given
  Target target;
  std::string temporary;  // full path, while it exists
  int slot = -1;
  bool written = false;
  std::string contents;  // in-place outputs: written at Commit

  void RemoveTemporary() noexcept {
    if (temporary.empty()) return;
    ::unlink(temporary.c_str());
    Unregister(slot);
    slot = -1;
    temporary.clear();
  }

  // Creates the temporary exclusively beside the target (O_EXCL|O_NOFOLLOW:
  // whatever is planted at the name, it is not opened) with the target's
  // permissions, or a plain new file's.
  int CreateTemporary() {
    InstallSignalHandlers();
    const mode_t mode = target.exists ? 0600 : 0666;  // 0666: the umask applies
    for (int attempt = 0; attempt < 100; ++attempt) {
      const std::string name = target.dir + "/" + TemporaryName(target.base, attempt);
      SignalsBlocked blocked;
      const int fd = ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, mode);
      if (fd < 0 && errno == EEXIST) continue;
      if (fd < 0) Fail(path, "cannot create a temporary file in " + target.dir, errno);
      temporary = name;
      slot = Register(name);
      if (target.exists) {
        // The owner first: chown clears the set-id bits that fchmod sets.
        if (target.st.st_uid != ::geteuid() || target.st.st_gid != ::getegid())
          (void)!::fchown(fd, target.st.st_uid, target.st.st_gid);
        if (::fchmod(fd, target.st.st_mode & 07777) != 0) {
          const int err = errno;
          ::close(fd);
          Fail(path, "cannot give the temporary file the target's permissions", err);
        }
      }
      return fd;
    }
    Fail(path, "no free name for a temporary file in " + target.dir, EEXIST);
  }

  void WriteTemporary(const std::function<void(std::ostream&)>& fill) {
    const int fd = CreateTemporary();
    int err = 0;
    std::string what;
    try {
      FdBuffer buffer(fd);
      std::ostream out(&buffer);
      fill(out);
      out.flush();
      if (!out) {
        err = buffer.error() ? buffer.error() : EIO;
        what = "write failed";
      }
    } catch (...) {
      ::close(fd);
      throw;
    }
    if (!err && ::fsync(fd) != 0) {
      err = errno;
      what = "cannot flush to disk";
    }
    if (::close(fd) != 0 && !err) {
      err = errno;
      what = "write failed";
    }
    if (err) Fail(path, what, err);
  }

  void WriteInPlace() {
    // One of our own descriptors (/dev/stdout, /dev/fd/N): written through
    // it, at its offset and with its flags (a shell's >> appends).
    const std::string own = "/proc/" + std::to_string(::getpid()) + "/fd/";
    if (target.final_path.rfind(own, 0) == 0) {
      char* end = nullptr;
      const long n = std::strtol(target.final_path.c_str() + own.size(), &end, 10);
      if (end && *end == '\0' && n >= 0 && n <= INT_MAX) {
        if (!WriteAll(static_cast<int>(n), contents.data(), contents.size()))
          Fail(path, "write failed", errno ? errno : EIO);
        return;
      }
    }
    const int fd = ::open(path.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) Fail(path, "cannot open for writing", errno);
    const bool ok = WriteAll(fd, contents.data(), contents.size());
    const int err = errno;
    ::close(fd);
    if (!ok) Fail(path, "write failed", err ? err : EIO);
  }
};

OutputSet::OutputSet() = default;
OutputSet::~OutputSet() { Discard(); }

void OutputSet::AddInput(const std::string& path) { inputs_.push_back(path); }

void OutputSet::AddOutput(const std::string& path) {
  auto o = std::make_unique<Output>();
  o->path = path;
  outputs_.push_back(std::move(o));
  checked_ = false;
}

namespace {

// The same file: the same place once links are followed, or the same inode.
bool SameFile(const Target& a, const Target& b) {
  if (a.exists && b.exists) return a.st.st_dev == b.st.st_dev && a.st.st_ino == b.st.st_ino;
  return a.final_path == b.final_path;
}

}  // namespace

void OutputSet::Check() {
  if (checked_) return;
  for (auto& o : outputs_) {
    o->target = Resolve(o->path);
    const Target& t = o->target;
    if (t.exists && S_ISDIR(t.st.st_mode)) Fail(o->path, "is a directory", EISDIR);
    if (t.in_place) {
      if (::faccessat(AT_FDCWD, o->path.c_str(), W_OK, AT_EACCESS) != 0)
        Fail(o->path, "cannot be written", errno);
    } else if (::faccessat(AT_FDCWD, t.dir.c_str(), W_OK | X_OK, AT_EACCESS) != 0) {
      Fail(o->path, "cannot write in the directory " + t.dir, errno);
    }
  }
  // Devices and FIFOs may be named twice (--report /dev/stdout -o /dev/stdout).
  for (size_t i = 0; i < outputs_.size(); ++i) {
    const Output& a = *outputs_[i];
    for (size_t j = i + 1; j < outputs_.size(); ++j) {
      const Output& b = *outputs_[j];
      if (!a.target.in_place && SameFile(a.target, b.target))
        throw std::runtime_error(b.path + ": the same file as the output " + a.path +
                                 " (each output needs a file of its own)");
    }
    for (const std::string& input : inputs_) {
      Target in;
      try {
        in = Resolve(input);
      } catch (const std::runtime_error&) {
        continue;  // an input that cannot be there cannot be overwritten; reading it says why
      }
      if (!(in.exists && !S_ISREG(in.st.st_mode)) && SameFile(a.target, in))
        throw std::runtime_error(a.path + ": the same file as the input " + input +
                                 " (an output may not overwrite an input)");
    }
  }
  checked_ = true;
}

void OutputSet::Abandon() noexcept {
  failed_ = true;
  Discard();
}

void OutputSet::Write(const std::string& path, const std::function<void(std::ostream&)>& fill) {
  if (committed_ || failed_) throw std::logic_error(path + ": written after the outputs were committed or discarded");
  Output* output = nullptr;
  for (auto& o : outputs_)
    if (o->path == path) output = o.get();
  if (!output) throw std::logic_error(path + ": not declared as an output");
  if (output->written) throw std::logic_error(path + ": written twice");
  try {
    Check();
    if (output->target.in_place) {
      std::ostringstream out;
      fill(out);
      output->contents = out.str();
    } else {
      output->WriteTemporary(fill);
    }
    output->written = true;
  } catch (...) {
    Abandon();
    throw;
  }
}

void OutputSet::Commit() {
  if (failed_) throw std::runtime_error("outputs not written: an earlier one failed");
  if (committed_) return;
  try {
    Check();
    for (auto& o : outputs_)
      if (o->written && o->target.in_place) o->WriteInPlace();
  } catch (...) {
    Abandon();
    throw;
  }
  // From here targets change: each rename is atomic, and with the
  // temporaries already beside their targets a failure is unlikely.
  committed_ = true;
  std::vector<const Output*> renamed;
  for (auto& o : outputs_) {
    if (!o->written || o->target.in_place) continue;
    if (::rename(o->temporary.c_str(), o->target.final_path.c_str()) != 0) {
      const int err = errno;
      Discard();
      Fail(o->path, "cannot rename the finished file into place", err);
    }
    Unregister(o->slot);
    o->slot = -1;
    o->temporary.clear();
    renamed.push_back(o.get());
  }
  // Each directory once: the renames survive a power cut from here.
  for (size_t i = 0; i < renamed.size(); ++i) {
    bool seen = false;
    for (size_t j = 0; j < i; ++j) seen = seen || renamed[j]->target.dir == renamed[i]->target.dir;
    if (!seen) SyncDirectory(renamed[i]->target.dir, renamed[i]->path);
  }
}

void OutputSet::Discard() noexcept {
  for (auto& o : outputs_) o->RemoveTemporary();
}

void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& fill) {
  OutputSet set;
  set.AddOutput(path);
  set.Write(path, fill);
  set.Commit();
}

}  // namespace cairn
