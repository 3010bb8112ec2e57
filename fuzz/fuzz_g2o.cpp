// libFuzzer target: the g2o reader on arbitrary bytes. Only ParseError (a
// clean "FILE:LINE: message") and std::invalid_argument from the graph may
// escape; anything else, a crash or a sanitizer report is a bug.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "cairn/graph/graph_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // "VERTEX_SE2" first keeps the fuzzer in the g2o branch of the reader.
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    cairn::ReadGraph(in, "fuzz.g2o");
  } catch (const cairn::ParseError&) {
  }
  return 0;
}
