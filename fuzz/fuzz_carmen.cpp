// libFuzzer target: the CARMEN log reader. It reads from a path (through
// zlib, which also takes gzip'd logs), so each input goes to a file first.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "cairn/graph/graph_io.h"
#include "cairn/frontend/carmen_log.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = "/tmp/cairn_fuzz_carmen_" + std::to_string(getpid()) + ".log";
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return 0;
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  try {
    cairn::frontend::ReadCarmenLog(path);
  } catch (const cairn::ParseError&) {
  }
  return 0;
}
