// A small option parser for the sub-commands: --name VALUE, --name=VALUE,
// boolean flags and positionals, with --help generated from the same table.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace cairn::tools {

class ArgParser {
 public:
  // `usage` is the line after "usage: cairn "; `description` a paragraph.
  ArgParser(std::string usage, std::string description);

  void Flag(const std::string& name, bool* out, const std::string& help);
  void Option(const std::string& name, std::string* out, const std::string& metavar,
              const std::string& help);
  void Option(const std::string& name, int* out, const std::string& metavar,
              const std::string& help);
  void Option(const std::string& name, double* out, const std::string& metavar,
              const std::string& help);
  // A single-letter alias for an option already declared ("-o" for "--output").
  void Alias(const std::string& alias, const std::string& name);
  void Positional(const std::string& name, std::string* out, const std::string& help,
                  bool required = true);

  // Parses argv (argv[0] is the sub-command's name). Returns false when the
  // command should exit now with *exit_code: 0 after --help, 2 on bad usage
  // (the error is printed to stderr with the usage line).
  bool Parse(int argc, char** argv, int* exit_code);
  std::string Help() const;

 private:
  struct Opt {
    std::string name, metavar, help;
    bool is_flag = false;
    std::function<bool(const std::string&)> set;  // false: bad value
    std::string default_text;
  };
  struct Pos {
    std::string name, help;
    std::string* out;
    bool required;
  };
  Opt* Find(const std::string& name);

  std::string usage_, description_;
  std::vector<Opt> options_;
  std::vector<std::pair<std::string, std::string>> aliases_;
  std::vector<Pos> positionals_;
};

// Options every sub-command accepts. main() takes them out of argv before
// the sub-command parses the rest, so no command declares them.
struct GlobalOptions {
  bool verbose = false;       // glog's lines (Ceres's and cairn's own) on stderr
  bool keep_unknown = false;  // ReadOptions::keep_unknown for every graph read
  bool repair_information = false;  // ReadOptions::repair_information, likewise
};
GlobalOptions& Globals();

// Removes --verbose, --keep-unknown and --repair-information from argv[1..*argc) (up to a "--"),
// setting them in *out; argv stays null-terminated.
void TakeGlobalOptions(int* argc, char** argv, GlobalOptions* out);

// The --help section that lists the global options.
std::string GlobalOptionsHelp();

// Shared by the sub-commands: prints "cairn: message" to stderr.
void PrintError(const std::string& message);

// Parses "3,17,42" into ids; throws std::invalid_argument on bad text.
std::vector<int64_t> ParseIdList(const std::string& text);

}  // namespace cairn::tools
