// `cairn`: one command with sub-commands, thin over the library.
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

#include <Eigen/Core>
#include <ceres/version.h>
#include <glog/logging.h>

#include "tools/args.h"
#include "tools/command.h"

namespace cairn::tools {

std::vector<Command>& Commands() {
  static std::vector<Command> commands;
  return commands;
}

namespace {

void PrintUsage(std::ostream& os) {
  auto commands = Commands();
  std::sort(commands.begin(), commands.end(),
            [](const Command& a, const Command& b) { return a.name < b.name; });
  os << "usage: cairn <command> [options]\n\n"
        "cairn: graph-SLAM back-end on Ceres, with a hand-written Gauss-Newton path\n"
        "beside it. Reads and writes pose graphs as g2o and as TORO (.graph).\n\ncommands:\n";
  for (const Command& c : commands)
    os << "  " << c.name << std::string(c.name.size() < 12 ? 12 - c.name.size() : 1, ' ')
       << c.summary << "\n";
  os << "\n'cairn <command> --help' describes a command's options; 'cairn --version' the build.\n"
     << GlobalOptionsHelp();
}

// What a bug report needs: cairn's version and the libraries it was built with.
void PrintVersion() {
  std::cout << "cairn " << CAIRN_VERSION_STRING << " (Ceres " << CERES_VERSION_STRING << ", Eigen "
            << EIGEN_WORLD_VERSION << '.' << EIGEN_MAJOR_VERSION << '.' << EIGEN_MINOR_VERSION
            << ")\n";
}

// Ceres (and cairn) log through glog, which would otherwise put its lines,
// and a warning about itself, first on stderr, ahead of cairn's own error
// when a solve fails: they show only with --verbose. Never into log files.
void InitLogging(const char* argv0, bool verbose) {
  FLAGS_logtostderr = true;
  FLAGS_minloglevel = verbose ? google::GLOG_INFO : google::GLOG_FATAL;
  google::InitGoogleLogging(argv0);
}

// A solve touches hundreds of megabytes of fresh memory, a page fault per
// 4 KiB; on virtual machines where one costs 10 us (the 2-core machines
// cairn is measured on) that was a third of a cold city10000 solve, for
// either solver. glibc (2.35 on) backs malloc's memory with transparent huge
// pages when its tunable asks, but reads tunables only as a process starts:
// so the commands that solve restart themselves once with it set (about
// 25 ms, against 300 ms saved on city10000). CAIRN_NO_HUGEPAGES=1 (or a
// kernel with huge pages off) keeps the process as it is. Which commands
// solve, each says as it registers (CAIRN_SOLVING_COMMAND). Inputs under
// kSmallInputBytes are solved as they are: on the shared files under 1 MB
// the restart cost about 4 ms of a 12-30 ms run (intel, MIT, CSAIL,
// smallGrid3D) or was level (manhattan, 0.6 MB); from sphere2500 (1.1 MB)
// up it pays.
constexpr std::uintmax_t kSmallInputBytes = 1000000;

bool SmallInput(char** argv) {
  for (char** a = argv + 2; *a; ++a) {
    std::error_code ec;
    if (**a == '-' || !std::filesystem::is_regular_file(*a, ec)) continue;
    const std::uintmax_t size = std::filesystem::file_size(*a, ec);
    return !ec && size < kSmallInputBytes;
  }
  return false;
}

void RestartWithHugePages(char** argv) {
  if (!argv[1] || std::none_of(Commands().begin(), Commands().end(), [&](const Command& c) {
        return c.solves && c.name == argv[1];
      }))
    return;
  if (SmallInput(argv)) return;
  if (std::getenv("CAIRN_NO_HUGEPAGES")) return;
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (tunables && std::strstr(tunables, "glibc.malloc.hugetlb")) return;
  std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode;
  if (!std::getline(thp, mode) || mode.find("[never]") != std::string::npos) return;
  const std::string value = tunables && *tunables
                                ? std::string(tunables) + ":glibc.malloc.hugetlb=1"
                                : std::string("glibc.malloc.hugetlb=1");
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  // The solvers hold OpenBLAS to one thread anyway (backend/linear/serial_scope.h);
  // unless asked otherwise, it then starts no worker, which would spin for
  // its first 0.1 s against the file's reading and the first linearisation.
  setenv("OPENBLAS_NUM_THREADS", "1", /*overwrite=*/0);
  execv("/proc/self/exe", argv);  // returns only on failure: carry on as we are
}

}  // namespace
}  // namespace cairn::tools

int main(int argc, char** argv) {
  using namespace cairn::tools;
  RestartWithHugePages(argv);
  TakeGlobalOptions(&argc, argv, &Globals());
  InitLogging(argv[0], Globals().verbose);
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") ||
      !std::strcmp(argv[1], "help")) {
    PrintUsage(argc < 2 ? std::cerr : std::cout);
    return argc < 2 ? 2 : 0;
  }
  if (!std::strcmp(argv[1], "--version") || !std::strcmp(argv[1], "version")) {
    PrintVersion();
    return 0;
  }
  for (const Command& c : Commands()) {
    if (c.name != argv[1]) continue;
    try {
      return c.run(argc - 1, argv + 1);
    } catch (const std::exception& e) {
      PrintError(e.what());
      return 1;
    }
  }
  PrintError(std::string("unknown command '") + argv[1] + "'");
  PrintUsage(std::cerr);
  return 2;
}
