// The `cairn` sub-command table. Each sub-command lives in its own
// cmd_<name>.cpp and registers itself with CAIRN_COMMAND (or
// CAIRN_SOLVING_COMMAND for one that runs a solver, which main() restarts
// with malloc on huge pages), so the tool's main() never needs editing to
// add one.
#pragma once

#include <string>
#include <vector>

namespace cairn::tools {

using CommandFn = int (*)(int argc, char** argv);

struct Command {
  std::string name;
  std::string summary;
  CommandFn run;
  bool solves = false;  // runs a solver: worth restarting with huge pages (main.cpp)
};

std::vector<Command>& Commands();

struct CommandRegistrar {
  CommandRegistrar(const char* name, const char* summary, CommandFn run, bool solves = false) {
    Commands().push_back({name, summary, run, solves});
  }
};

}  // namespace cairn::tools

#define CAIRN_COMMAND(name, summary, fn) \
  static ::cairn::tools::CommandRegistrar cairn_command_registrar_##fn(name, summary, fn)
#define CAIRN_SOLVING_COMMAND(name, summary, fn) \
  static ::cairn::tools::CommandRegistrar cairn_command_registrar_##fn(name, summary, fn, true)
