#include "tools/args.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <sstream>

namespace cairn::tools {
namespace {

bool ParseInt(const std::string& s, int* out) {
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || errno != 0 || v < INT32_MIN || v > INT32_MAX) return false;
  *out = static_cast<int>(v);
  return true;
}

bool ParseDouble(const std::string& s, double* out) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || errno != 0 || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

std::string Shorten(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

ArgParser::ArgParser(std::string usage, std::string description)
    : usage_(std::move(usage)), description_(std::move(description)) {
  options_.push_back({"help", "", "show this help and exit", true, nullptr, ""});
}

void ArgParser::Flag(const std::string& name, bool* out, const std::string& help) {
  options_.push_back({name, "", help, true,
                      [out](const std::string&) {
                        *out = true;
                        return true;
                      },
                      ""});
}

void ArgParser::Option(const std::string& name, std::string* out, const std::string& metavar,
                       const std::string& help) {
  options_.push_back({name, metavar, help, false,
                      [out](const std::string& v) {
                        *out = v;
                        return true;
                      },
                      *out});
}

void ArgParser::Option(const std::string& name, int* out, const std::string& metavar,
                       const std::string& help) {
  options_.push_back({name, metavar, help, false,
                      [out](const std::string& v) { return ParseInt(v, out); },
                      std::to_string(*out)});
}

void ArgParser::Option(const std::string& name, double* out, const std::string& metavar,
                       const std::string& help) {
  options_.push_back({name, metavar, help, false,
                      [out](const std::string& v) { return ParseDouble(v, out); },
                      Shorten(*out)});
}

void ArgParser::Alias(const std::string& alias, const std::string& name) {
  aliases_.emplace_back(alias, name);
}

void ArgParser::Positional(const std::string& name, std::string* out, const std::string& help,
                           bool required) {
  positionals_.push_back({name, help, out, required});
}

ArgParser::Opt* ArgParser::Find(const std::string& name) {
  for (Opt& o : options_)
    if (o.name == name) return &o;
  return nullptr;
}

bool ArgParser::Parse(int argc, char** argv, int* exit_code) {
  auto fail = [&](const std::string& msg) {
    PrintError(msg);
    std::cerr << "usage: cairn " << usage_ << "\n(see 'cairn " << argv[0] << " --help')\n";
    *exit_code = 2;
    return false;
  };
  size_t next_pos = 0;
  bool only_positionals = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (!only_positionals && arg == "--") {
      only_positionals = true;
      continue;
    }
    if (!only_positionals && arg.size() > 1 && arg[0] == '-' &&
        !(std::isdigit(static_cast<unsigned char>(arg[1])) || arg[1] == '.')) {
      std::string name, value;
      bool has_value = false;
      if (arg.rfind("--", 0) == 0) {
        name = arg.substr(2);
        const size_t eq = name.find('=');
        if (eq != std::string::npos) {
          value = name.substr(eq + 1);
          name = name.substr(0, eq);
          has_value = true;
        }
      } else {
        name = arg;
        for (const auto& [alias, target] : aliases_)
          if (alias == arg) name = target;
      }
      if (name == "help" || arg == "-h") {
        std::cout << Help();
        *exit_code = 0;
        return false;
      }
      Opt* opt = Find(name);
      if (!opt) return fail("unknown option '" + arg + "'");
      if (opt->is_flag) {
        if (has_value) return fail("option --" + name + " takes no value");
        opt->set("");
        continue;
      }
      if (!has_value) {
        if (i + 1 >= argc) return fail("option --" + name + " needs a value (" + opt->metavar + ")");
        value = argv[++i];
      }
      if (!opt->set(value))
        return fail("bad value '" + value + "' for --" + name + " (expected " + opt->metavar + ")");
      continue;
    }
    if (next_pos >= positionals_.size()) return fail("unexpected argument '" + arg + "'");
    *positionals_[next_pos++].out = arg;
  }
  for (size_t k = next_pos; k < positionals_.size(); ++k)
    if (positionals_[k].required) return fail("missing argument " + positionals_[k].name);
  return true;
}

std::string ArgParser::Help() const {
  std::ostringstream os;
  os << "usage: cairn " << usage_ << "\n\n" << description_ << "\n";
  if (!positionals_.empty()) {
    os << "\narguments:\n";
    for (const Pos& p : positionals_) {
      std::string head = "  " + p.name;
      os << head << std::string(head.size() < 26 ? 26 - head.size() : 1, ' ') << p.help
         << (p.required ? "" : " (optional)") << "\n";
    }
  }
  os << "\noptions:\n";
  for (const Opt& o : options_) {
    std::string head = "  ";
    for (const auto& [alias, target] : aliases_)
      if (target == o.name) head += alias + ", ";
    head += "--" + o.name + (o.metavar.empty() ? "" : " " + o.metavar);
    os << head << std::string(head.size() < 26 ? 26 - head.size() : 1, ' ') << o.help;
    if (!o.is_flag && !o.default_text.empty()) os << " [default: " << o.default_text << "]";
    os << "\n";
  }
  os << GlobalOptionsHelp();
  return os.str();
}

void PrintError(const std::string& message) { std::cerr << "cairn: " << message << "\n"; }

std::vector<int64_t> ParseIdList(const std::string& text) {
  std::vector<int64_t> ids;
  size_t pos = 0;
  while (pos <= text.size()) {
    const size_t comma = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, comma - pos);
    char* end = nullptr;
    const long long id = std::strtoll(item.c_str(), &end, 10);
    if (item.empty() || *end != '\0')
      throw std::invalid_argument("bad vertex id '" + item + "' in '" + text +
                                  "' (expected ids separated by commas, e.g. 3,17,42)");
    ids.push_back(id);
    pos = comma + 1;
  }
  return ids;
}

GlobalOptions& Globals() {
  static GlobalOptions options;
  return options;
}

void TakeGlobalOptions(int* argc, char** argv, GlobalOptions* out) {
  int kept = 1;
  bool only_positionals = false;
  for (int i = 1; i < *argc; ++i) {
    const std::string arg = argv[i];
    only_positionals |= arg == "--";
    if (!only_positionals && arg == "--verbose") {
      out->verbose = true;
    } else if (!only_positionals && arg == "--keep-unknown") {
      out->keep_unknown = true;
    } else if (!only_positionals && arg == "--repair-information") {
      out->repair_information = true;
    } else {
      argv[kept++] = argv[i];
    }
  }
  argv[kept] = nullptr;
  *argc = kept;
}

std::string GlobalOptionsHelp() {
  return "\nglobal options (every command):\n"
         "  --verbose               also show the solvers' log lines (glog, Ceres's and cairn's)\n"
         "  --keep-unknown          carry lines with tags cairn does not know through verbatim\n"
         "                          (written back in place by g2o output) instead of refusing them\n"
         "  --repair-information    replace each indefinite information matrix by the nearest\n"
         "                          positive semi-definite one (negative eigenvalues set to zero)\n"
         "                          instead of refusing the file; says how many on stderr, and\n"
         "                          the reports count them\n";
}

}  // namespace cairn::tools
