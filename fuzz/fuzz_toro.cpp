// libFuzzer target: the TORO reader (VERTEX2/EDGE2/VERTEX3/EDGE3 lines).
// Each input is prefixed with a TORO tag so that the fuzzer spends its time
// in that branch of the reader rather than rediscovering the tag.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "cairn/graph/graph_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string body(reinterpret_cast<const char*>(data), size);
  std::istringstream in((size % 2 ? "VERTEX2 0 0 0 0\n" : "VERTEX3 0 0 0 0 0 0 0\n") + body);
  try {
    cairn::ReadGraph(in, "fuzz.graph");
  } catch (const cairn::ParseError&) {
  }
  return 0;
}
