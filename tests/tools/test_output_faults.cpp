// Every `cairn` command's outputs, end to end: each path checked before any
// work (outputs distinct from each other and from the inputs, directories
// there, known extensions), and all written or none changed.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/simulate.h"
#include "test_util.h"

namespace cairn {
namespace {

namespace fs = std::filesystem;

std::string Tool() { return CAIRN_TOOL; }

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void Put(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// A directory of the test's own, and a small 2D graph in it.
struct Scene {
  std::string dir, in;
  explicit Scene(const std::string& name) {
    dir = testing::TempDir() + "/" + name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    in = dir + "/in.g2o";
    SimulationOptions o;
    o.dimension = 2;
    o.poses = 60;
    o.seed = 3;
    WriteG2o(Simulate(o).noisy, in);
  }
  std::string operator/(const std::string& name) const { return dir + "/" + name; }
};

// Runs `cairn ARGS`, stderr with stdout; *status gets the exit code.
std::string Cairn(const std::string& args, int* status) {
  return testing::RunCommand(Tool() + " " + args + " 2>&1", status);
}

// What a refusal before any work looks like: cairn's own error first, no
// progress line of a solve.
void ExpectRefusedBeforeWork(const std::string& log, int status, const std::string& a,
                             const std::string& b = "") {
  EXPECT_NE(status, 0) << log;
  EXPECT_EQ(log.rfind("cairn: ", 0), 0u) << log;
  EXPECT_NE(log.find(a), std::string::npos) << log;
  if (!b.empty()) EXPECT_NE(log.find(b), std::string::npos) << log;
  EXPECT_EQ(log.find("iter "), std::string::npos) << log;
  EXPECT_EQ(log.find("chi2"), std::string::npos) << log;
}

// No temporary left beside the outputs: only these names in the directory.
void ExpectOnly(const std::string& dir, std::set<std::string> names) {
  std::set<std::string> seen;
  for (const auto& e : fs::directory_iterator(dir)) seen.insert(e.path().filename().string());
  EXPECT_EQ(seen, names);
}

TEST(OutputFaults, ReportEqualToTheGraphOutputIsRefused) {
  Scene s("report_is_out");
  const std::string out = s / "out.g2o";
  Put(out, "old\n");
  int status = 0;
  std::string log = Cairn("optimize " + s.in + " -o " + out + " --report " + out, &status);
  ExpectRefusedBeforeWork(log, status, out + ": the same file as the output " + out);
  EXPECT_EQ(Slurp(out), "old\n");
  // The same file through a symlink is the same file.
  fs::create_symlink(out, s / "link.json");
  log = Cairn("optimize " + s.in + " -o " + out + " --report " + (s / "link.json"), &status);
  ExpectRefusedBeforeWork(log, status, s / "link.json", out);
  EXPECT_EQ(Slurp(out), "old\n");
  ExpectOnly(s.dir, {"in.g2o", "out.g2o", "link.json"});
}

TEST(OutputFaults, PlotOrReportEqualToTheInputIsRefused) {
  Scene s("output_is_input");
  const std::string before = Slurp(s.in);
  for (const std::string option : {"--plot", "--report"}) {
    int status = 0;
    const std::string log =
        Cairn("optimize " + s.in + " -o " + (s / "out.g2o") + " " + option + " " + s.in, &status);
    ExpectRefusedBeforeWork(log, status, s.in + ": the same file as the input " + s.in);
    EXPECT_EQ(Slurp(s.in), before) << option;
  }
  ExpectOnly(s.dir, {"in.g2o"});
}

TEST(OutputFaults, EveryCommandRefusesAnOutputThatIsAnotherOrAnInput) {
  Scene s("others");
  const std::string json = s / "r.json";
  Put(json, "old\n");
  const std::string cases[] = {
      "corrupt " + s.in + " -o " + (s / "c.g2o") + " --outliers 2 --list " + (s / "c.g2o"),
      "simulate -o " + (s / "sim.g2o") + " --truth " + (s / "sim.g2o"),
      "compare " + s.in + " --json " + s.in,
      "eval " + s.in + " " + s.in + " --json " + s.in,
      "calibrate --g2o " + s.in + " --odometry " + s.in + " --json " + json + " --pairs-out " + json,
  };
  for (const std::string& c : cases) {
    int status = 0;
    const std::string log = Cairn(c, &status);
    ExpectRefusedBeforeWork(log, status, "the same file as the");
  }
  EXPECT_EQ(Slurp(json), "old\n");
  ExpectOnly(s.dir, {"in.g2o", "r.json"});
}

TEST(OutputFaults, ReportInAMissingDirectoryFailsBeforeTheSolveAndLeavesTheGraph) {
  Scene s("nodir");
  const std::string out = s / "out.g2o";
  Put(out, "old\n");
  int status = 0;
  const std::string log =
      Cairn("optimize " + s.in + " -o " + out + " --report " + (s / "nodir/r.json"), &status);
  ExpectRefusedBeforeWork(log, status, s / "nodir/r.json", s / "nodir");
  EXPECT_EQ(Slurp(out), "old\n");
  ExpectOnly(s.dir, {"in.g2o", "out.g2o"});
}

TEST(OutputFaults, AnUnknownOutputExtensionIsRefusedBeforeWork) {
  Scene s("extension");
  for (const std::string args : {"optimize " + s.in + " -o " + (s / "x.txt"),
                                 "optimize " + s.in + " -o " + (s / "x.g2o") + " --plot " + (s / "p.png"),
                                 "corrupt " + s.in + " -o " + (s / "x.toro") + " --outliers 1",
                                 "simulate -o " + (s / "x.g2o") + " --truth " + (s / "t.txt")}) {
    int status = 0;
    const std::string log = Cairn(args, &status);
    ExpectRefusedBeforeWork(log, status, "an output extension cairn does not know");
  }
  ExpectOnly(s.dir, {"in.g2o"});
  // The extension in any case.
  int status = -1;
  const std::string log = Cairn("simulate -o " + (s / "X.G2O") + " --poses 20", &status);
  EXPECT_EQ(status, 0) << log;
}

TEST(OutputFaults, ASymlinkPlantedAtAPredictableTemporaryNameIsNotFollowed) {
  Scene s("planted");
  const std::string out = s / "out.g2o", victim = s / "victim";
  Put(victim, "precious\n");
  // cairn's old name was ".out.g2o.tmp.PID": planted for the pids likely
  // next (the machine's last pid onwards), with other common ones.
  std::vector<std::string> planted = {out + ".tmp", s / ".out.g2o.tmp", out + "~", out + ".part"};
  long last_pid = 0;
  std::ifstream("/proc/sys/kernel/ns_last_pid") >> last_pid;
  for (long pid = last_pid + 1; pid <= last_pid + 400; ++pid)
    planted.push_back(s / (".out.g2o.tmp." + std::to_string(pid)));
  for (const std::string& p : planted) fs::create_symlink(victim, p);
  int status = -1;
  const std::string log = Cairn("optimize --quiet " + s.in + " -o " + out, &status);
  ASSERT_EQ(status, 0) << log;
  EXPECT_EQ(Slurp(victim), "precious\n");
  for (const std::string& p : planted) EXPECT_TRUE(fs::is_symlink(p)) << p;
  EXPECT_EQ(ReadGraph(out).vertices().size(), 60u);
}

TEST(OutputFaults, AReportToAFifoIsWrittenInPlace) {
  Scene s("fifo");
  const std::string fifo = s / "report.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string received;
  std::atomic<bool> done{false};
  std::thread reader([&] {
    received = Slurp(fifo);
    done = true;
  });
  int status = -1;
  const std::string log =
      Cairn("optimize --quiet " + s.in + " -o " + (s / "out.g2o") + " --report " + fifo, &status);
  if (!done) {
    // cairn never opened it: let the reader see an end.
    const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) ::close(fd);
  }
  reader.join();
  ASSERT_EQ(status, 0) << log;
  EXPECT_GT(testing::JsonNumber(received, "final_chi2"), 0) << received;
  struct stat st {};
  ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
}

TEST(OutputFaults, AModeOf0600Stays) {
  Scene s("mode");
  const std::string out = s / "out.g2o", report = s / "r.json";
  for (const std::string& p : {out, report}) {
    Put(p, "old\n");
    ASSERT_EQ(::chmod(p.c_str(), 0600), 0);
  }
  int status = -1;
  const std::string log =
      Cairn("optimize --quiet " + s.in + " -o " + out + " --report " + report, &status);
  ASSERT_EQ(status, 0) << log;
  for (const std::string& p : {out, report}) {
    struct stat st {};
    ASSERT_EQ(::stat(p.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 07777, 0600u) << p;
    EXPECT_NE(Slurp(p), "old\n") << p;
  }
}

TEST(OutputFaults, MapWithAnUnwritableOutputLeavesNoGridBehind) {
  Scene s("map");
  const std::string log_path = s / "run.log";
  Put(log_path, "ODOM 0 0 0 0 0 0 1 h 1\n");  // never read: the outputs fail first
  // An old map whose PNG's place is taken by a directory; and a new one.
  Put(s / "old.pgm", "old pgm\n");
  Put(s / "old.yaml", "old yaml\n");
  fs::create_directory(s / "old.png");
  fs::create_directory(s / "new.png");
  for (const std::string prefix : {"old", "new"}) {
    int status = 0;
    const std::string log = Cairn("map " + log_path + " -o " + (s / prefix), &status);
    ExpectRefusedBeforeWork(log, status, s / (prefix + ".png"), "is a directory");
  }
  EXPECT_EQ(Slurp(s / "old.pgm"), "old pgm\n");
  EXPECT_EQ(Slurp(s / "old.yaml"), "old yaml\n");
  ExpectOnly(s.dir, {"in.g2o", "run.log", "old.pgm", "old.yaml", "old.png", "new.png"});
}

}  // namespace
}  // namespace cairn
