// `cairn`: one command with sub-commands, thin over the library.
#include <algorithm>
#include <cstring>
#include <exception>
#include <iostream>

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
        "beside it. Reads and writes g2o pose graphs (and reads TORO).\n\ncommands:\n";
  for (const Command& c : commands)
    os << "  " << c.name << std::string(c.name.size() < 12 ? 12 - c.name.size() : 1, ' ')
       << c.summary << "\n";
  os << "\n'cairn <command> --help' describes a command's options.\n";
}

}  // namespace
}  // namespace cairn::tools

int main(int argc, char** argv) {
  using namespace cairn::tools;
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") ||
      !std::strcmp(argv[1], "help")) {
    PrintUsage(argc < 2 ? std::cerr : std::cout);
    return argc < 2 ? 2 : 0;
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
