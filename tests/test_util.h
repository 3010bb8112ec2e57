// Shared helpers for the gtest suites: where the real datasets are, how
// to skip a test cleanly when they are not there, and small edits of graphs.
#pragma once

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <string>

#include "cairn/graph/pose_graph.h"

namespace cairn::testing {

// A directory of this test process's own under the system's temporary one:
// CTest runs test cases as parallel processes (and two builds' suites may
// run at once), so fixed file names there would be shared between them.
inline const std::string& TempDirPath() {
  // Never destroyed: the exit handler below still needs it.
  static const std::string* dir =
      new std::string(::testing::TempDir() + "cairn_test_" + std::to_string(::getpid()));
  return *dir;
}
inline std::string TempDir() {
  static const bool made = [] {
    ::mkdir(TempDirPath().c_str(), 0700);
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(TempDirPath(), ignored);
    });
    return true;
  }();
  (void)made;
  return TempDirPath();
}

inline std::string DatasetPath(const std::string& relative) {
  return std::string(CAIRN_DATASETS) + "/" + relative;
}

// Runs a shell command; returns its standard output and sets *status to
// its exit code (-1 if it could not be started).
inline std::string RunCommand(const std::string& command, int* status) {
  std::array<char, 4096> buf;
  std::string out;
  *status = -1;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return out;
  while (fgets(buf.data(), buf.size(), pipe)) out += buf.data();
  const int raw = pclose(pipe);
  *status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return out;
}

// The number after "key": in a flat JSON text, or NaN when absent.
inline double JsonNumber(const std::string& json, const std::string& key) {
  std::smatch m;
  if (!std::regex_search(json, m, std::regex("\"" + key + "\": *([-0-9.eE+]+)")))
    return std::nan("");
  return std::stod(m[1]);
}

// Every edge's information times s (a graph looser or tighter than its noise).
inline void ScaleInformation(PoseGraph& graph, double s) {
  for (size_t k = 0; k < graph.edges().size(); ++k) {
    Edge e = graph.edges()[k];
    e.information *= s;
    graph.SetEdge(k, e);
  }
}

}  // namespace cairn::testing

// Skips the current test with a clear message when a shared dataset is absent.
#define CAIRN_REQUIRE_DATASET(path)                                        \
  do {                                                                     \
    if (!std::filesystem::exists(path)) {                                  \
      GTEST_SKIP() << "dataset not found: " << (path)                      \
                   << " (the shared datasets are not beside this clone)";  \
    }                                                                      \
  } while (0)

// Sanitizer builds run every suite's shorter tests; the longest numerical
// agreement tests (many solves of code those shorter tests already run)
// skip there and run in Release builds.
#if defined(__SANITIZE_ADDRESS__)
#define CAIRN_LONG_NUMERICAL_TEST() \
  GTEST_SKIP() << "a long numerical agreement test: Release builds run it"
#else
#define CAIRN_LONG_NUMERICAL_TEST() static_cast<void>(0)
#endif
