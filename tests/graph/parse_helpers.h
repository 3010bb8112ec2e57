// Reading a graph from text in a test, and expecting the reader's FILE:LINE
// error: shared by the suites of backend/graph's readers.
#pragma once

#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "cairn/graph/graph_io.h"

namespace cairn::testing {

// The name the parsed text goes by in errors.
inline const char* kParsedName = "in.g2o";

inline PoseGraph Parse(const std::string& text, ReadOptions options = {}) {
  std::istringstream in(text);
  return ReadGraph(in, kParsedName, options);
}

// Expects "in.g2o:LINE: ..." whose message contains `what`.
inline void ExpectError(const std::string& text, size_t line, const std::string& what,
                        ReadOptions options = {}) {
  try {
    Parse(text, options);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(std::string(e.what()).rfind(std::string(kParsedName) + ":" + std::to_string(line) +
                                              ": ", 0),
              0u)
        << e.what();
    EXPECT_NE(e.message().find(what), std::string::npos) << e.what();
  }
}

}  // namespace cairn::testing
