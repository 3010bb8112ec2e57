// Safe writes and all-or-nothing outputs (backend/graph/output_files.h):
// planted symlinks, FIFOs, symlinked outputs, permissions, failures, and a
// signal in the middle of a write. Everything happens in a directory of the
// test's own, never in the machine's /dev.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>

#include "cairn/graph/output_files.h"
#include "test_util.h"

namespace fs = std::filesystem;
using cairn::OutputSet;
using cairn::WriteFileAtomically;

namespace {

// A fresh directory per test, removed afterwards.
class OutputFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(cairn::testing::TempDir()) / (std::string("out_") + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    cairn::SetTemporaryNamesForTesting(nullptr);
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  // Names in the directory other than `keep`: temporaries left behind.
  std::vector<std::string> Others(std::initializer_list<std::string> keep) const {
    std::vector<std::string> left;
    for (const auto& e : fs::directory_iterator(dir_)) {
      const std::string name = e.path().filename().string();
      if (std::find(keep.begin(), keep.end(), name) == keep.end()) left.push_back(name);
    }
    return left;
  }
  fs::path dir_;
};

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void Put(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

auto Text(const std::string& text) {
  return [text](std::ostream& os) { os << text; };
}

}  // namespace

TEST_F(OutputFiles, WritesAndReplaces) {
  const std::string out = Path("out.txt");
  WriteFileAtomically(out, Text("first\n"));
  EXPECT_EQ(Slurp(out), "first\n");
  WriteFileAtomically(out, Text("second\n"));
  EXPECT_EQ(Slurp(out), "second\n");
  EXPECT_TRUE(Others({"out.txt"}).empty());
}

TEST_F(OutputFiles, PlantedSymlinkAtEveryTemporaryNameIsNotFollowed) {
  const std::string victim = Path("victim"), out = Path("out.g2o");
  Put(victim, "precious\n");
  // The old predictable name, and every name the writer will try.
  fs::create_symlink(victim, Path(".out.g2o.tmp." + std::to_string(::getpid())));
  fs::create_symlink(victim, Path("planted"));
  cairn::SetTemporaryNamesForTesting([](int) { return std::string("planted"); });
  EXPECT_THROW(WriteFileAtomically(out, Text("attack\n")), std::runtime_error);
  EXPECT_EQ(Slurp(victim), "precious\n");
  EXPECT_FALSE(fs::exists(out));
  // With a free name after the planted ones, the write goes through and
  // still leaves the victim alone.
  cairn::SetTemporaryNamesForTesting(
      [](int attempt) { return attempt < 3 ? std::string("planted") : std::string(".free.tmp"); });
  WriteFileAtomically(out, Text("graph\n"));
  EXPECT_EQ(Slurp(out), "graph\n");
  EXPECT_EQ(Slurp(victim), "precious\n");
  EXPECT_TRUE(fs::is_symlink(Path("planted")));
}

TEST_F(OutputFiles, RandomTemporaryNamesDiffer) {
  // Seen through a fill that lists the directory while its temporary exists.
  std::string seen[2];
  for (std::string& name : seen) {
    WriteFileAtomically(Path("out"), [&](std::ostream& os) {
      for (const auto& e : fs::directory_iterator(dir_))
        if (e.path().filename() != "out") name = e.path().filename().string();
      os << "x";
    });
  }
  EXPECT_FALSE(seen[0].empty());
  EXPECT_NE(seen[0], seen[1]);
  EXPECT_EQ(seen[0].find(std::to_string(::getpid())), std::string::npos);
}

TEST_F(OutputFiles, FifoIsWrittenInPlace) {
  const std::string fifo = Path("pipe");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string got;
  std::thread reader([&] { got = Slurp(fifo); });
  WriteFileAtomically(fifo, Text("through the pipe\n"));
  reader.join();
  EXPECT_EQ(got, "through the pipe\n");
  struct stat st {};
  ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  EXPECT_TRUE(Others({"pipe"}).empty());
}

TEST_F(OutputFiles, DeviceIsWrittenInPlace) {
  // A null device of the test's own (as root), never the machine's /dev/null.
  const std::string null = Path("null");
  if (::mknod(null.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0)
    GTEST_SKIP() << "cannot make a device node here (not root)";
  const int probe = ::open(null.c_str(), O_WRONLY);
  if (probe < 0) GTEST_SKIP() << "device nodes do not open here (a nodev mount)";
  ::close(probe);
  WriteFileAtomically(null, Text("report\n"));
  struct stat st {};
  ASSERT_EQ(::lstat(null.c_str(), &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  EXPECT_TRUE(Others({"null"}).empty());
  OutputSet twice;  // a device may take two outputs
  twice.AddOutput(null);
  twice.AddOutput(null);
  EXPECT_NO_THROW(twice.Check());
}

TEST_F(OutputFiles, OwnDescriptorIsWrittenThroughAtItsOffset) {
  // As /dev/stdout under `>>`: a link of our own to /proc/self/fd/N.
  const std::string log = Path("log.txt"), link = Path("stdout");
  Put(log, "kept\n");
  const int fd = ::open(log.c_str(), O_WRONLY | O_APPEND);
  ASSERT_GE(fd, 0);
  fs::create_symlink("/proc/self/fd/" + std::to_string(fd), link);
  WriteFileAtomically(link, Text("appended\n"));
  ::close(fd);
  EXPECT_EQ(Slurp(log), "kept\nappended\n");
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_TRUE(Others({"log.txt", "stdout"}).empty());
}

TEST_F(OutputFiles, SymlinkOutputUpdatesItsTargetAndStaysALink) {
  fs::create_directories(dir_ / "real");
  const std::string target = Path("real/target.g2o"), link = Path("link.g2o");
  Put(target, "old\n");
  fs::create_symlink("real/target.g2o", link);  // relative, as ln -s makes them
  WriteFileAtomically(link, Text("new\n"));
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(Slurp(target), "new\n");
  // A dangling link creates its target.
  const std::string dangling = Path("dangling.g2o");
  fs::create_symlink(Path("real/created.g2o"), dangling);
  WriteFileAtomically(dangling, Text("made\n"));
  EXPECT_TRUE(fs::is_symlink(dangling));
  EXPECT_EQ(Slurp(Path("real/created.g2o")), "made\n");
  EXPECT_TRUE(Others({"real", "link.g2o", "dangling.g2o"}).empty());
}

TEST_F(OutputFiles, ModeIsKept) {
  const std::string out = Path("secret.json");
  Put(out, "old");
  ASSERT_EQ(::chmod(out.c_str(), 0600), 0);
  WriteFileAtomically(out, Text("new"));
  struct stat st {};
  ASSERT_EQ(::stat(out.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0600u);
  // A new file: what a plain open with 0666 under the umask gives.
  const mode_t mask = ::umask(022);
  ::umask(mask);
  const std::string fresh = Path("fresh.json");
  WriteFileAtomically(fresh, Text("x"));
  ASSERT_EQ(::stat(fresh.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0666u & ~mask);
}

TEST_F(OutputFiles, FailingFillKeepsTheOldContents) {
  const std::string out = Path("out.g2o");
  Put(out, "old\n");
  EXPECT_THROW(WriteFileAtomically(out,
                                   [](std::ostream& os) {
                                     os << "half";
                                     throw std::runtime_error("interrupted");
                                   }),
               std::runtime_error);
  EXPECT_EQ(Slurp(out), "old\n");
  EXPECT_TRUE(Others({"out.g2o"}).empty());
}

TEST_F(OutputFiles, ErrorsNameThePath) {
  const std::string out = Path("missing/out.g2o");
  try {
    WriteFileAtomically(out, Text("x"));
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(out + ": ", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("No such file or directory"), std::string::npos) << e.what();
  }
  EXPECT_THROW(WriteFileAtomically(dir_.string(), Text("x")), std::runtime_error);
}

TEST_F(OutputFiles, OutputSetRefusesCollisions) {
  const std::string in = Path("in.g2o"), out = Path("out.g2o");
  Put(in, "input\n");
  auto refused = [](OutputSet& set, const std::string& a, const std::string& b) {
    try {
      set.Check();
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(a), std::string::npos) << what;
      EXPECT_NE(what.find(b), std::string::npos) << what;
      return true;
    }
    return false;
  };
  {  // the same path twice
    OutputSet set;
    set.AddOutput(out);
    set.AddOutput(out);
    EXPECT_TRUE(refused(set, out, out));
  }
  {  // the same path, spelled differently
    OutputSet set;
    set.AddOutput(out);
    set.AddOutput(Path("./out.g2o"));
    EXPECT_TRUE(refused(set, out, Path("./out.g2o")));
  }
  {  // the same file through a symlink
    Put(out, "old\n");
    fs::create_symlink(out, Path("alias.g2o"));
    OutputSet set;
    set.AddOutput(out);
    set.AddOutput(Path("alias.g2o"));
    EXPECT_TRUE(refused(set, out, Path("alias.g2o")));
  }
  {  // an output equal to an input, directly and through a hard link
    fs::create_hard_link(in, Path("hard.g2o"));
    OutputSet set;
    set.AddInput(in);
    set.AddOutput(Path("hard.g2o"));
    EXPECT_TRUE(refused(set, in, Path("hard.g2o")));
    OutputSet direct;
    direct.AddInput(in);
    direct.AddOutput(in);
    EXPECT_TRUE(refused(direct, in, in));
  }
  {  // a missing directory, and a directory as output
    OutputSet set;
    set.AddOutput(Path("nodir/r.json"));
    EXPECT_THROW(set.Check(), std::runtime_error);
    OutputSet d;
    d.AddOutput(dir_.string());
    EXPECT_THROW(d.Check(), std::runtime_error);
  }
  {  // distinct files pass
    OutputSet set;
    set.AddInput(in);
    set.AddOutput(out);
    set.AddOutput(Path("report.json"));
    EXPECT_NO_THROW(set.Check());
  }
  EXPECT_EQ(Slurp(in), "input\n");
}

TEST_F(OutputFiles, OutputSetIsAllOrNothing) {
  const std::string a = Path("a"), b = Path("b"), c = Path("c");
  for (const std::string& p : {a, b, c}) Put(p, "old " + p);
  {
    OutputSet set;
    for (const std::string& p : {a, b, c}) set.AddOutput(p);
    set.Check();
    set.Write(a, Text("new a"));
    EXPECT_THROW(set.Write(b, [](std::ostream&) { throw std::runtime_error("disk full"); }),
                 std::runtime_error);
    EXPECT_THROW(set.Write(c, Text("new c")), std::logic_error);
    EXPECT_THROW(set.Commit(), std::runtime_error);
  }
  for (const std::string& p : {a, b, c}) EXPECT_EQ(Slurp(p), "old " + p);
  EXPECT_TRUE(Others({"a", "b", "c"}).empty());
  {  // destroyed without Commit
    OutputSet set;
    set.AddOutput(a);
    set.Write(a, Text("new a"));
  }
  EXPECT_EQ(Slurp(a), "old " + a);
  EXPECT_TRUE(Others({"a", "b", "c"}).empty());
  {  // all written: all in place
    OutputSet set;
    for (const std::string& p : {a, b, c}) set.AddOutput(p);
    for (const std::string& p : {a, b, c}) set.Write(p, Text("new " + p));
    set.Commit();
  }
  for (const std::string& p : {a, b, c}) EXPECT_EQ(Slurp(p), "new " + p);
  EXPECT_TRUE(Others({"a", "b", "c"}).empty());
}

TEST_F(OutputFiles, SigtermDuringAWriteLeavesNoTemporary) {
  const std::string out = Path("out.g2o");
  Put(out, "old\n");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    try {
      WriteFileAtomically(out, [](std::ostream& os) {
        os << "half of it" << std::flush;
        for (;;) ::pause();
      });
    } catch (...) {
    }
    ::_exit(3);
  }
  // Wait for the child's temporary to appear, then stop it.
  bool seen = false;
  for (int k = 0; k < 2000 && !seen; ++k) {
    seen = !Others({"out.g2o"}).empty();
    if (!seen) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_TRUE(seen) << "the child's temporary never appeared";
  ASSERT_EQ(::kill(child, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM) << "status " << status;
  EXPECT_EQ(Slurp(out), "old\n");
  EXPECT_TRUE(Others({"out.g2o"}).empty()) << "temporary left behind";
}
