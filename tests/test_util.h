// Shared helpers for the gtest suites: where the real datasets are, and how
// to skip a test cleanly when they are not there.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace cairn::testing {

inline std::string DatasetPath(const std::string& relative) {
  return std::string(CAIRN_DATASETS) + "/" + relative;
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
