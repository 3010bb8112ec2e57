// Shared helpers for the gtest suites: where the real datasets are, and how
// to skip a test cleanly when they are not there.
#pragma once

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <string>

namespace cairn::testing {

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

}  // namespace cairn::testing

// Skips the current test with a clear message when a shared dataset is absent.
#define CAIRN_REQUIRE_DATASET(path)                                        \
  do {                                                                     \
    if (!std::filesystem::exists(path)) {                                  \
      GTEST_SKIP() << "dataset not found: " << (path)                      \
                   << " (the shared datasets are not beside this clone)";  \
    }                                                                      \
  } while (0)
