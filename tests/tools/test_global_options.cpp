// The options every sub-command takes (--verbose, --keep-unknown): main()
// takes them out of argv before the sub-command's own parser sees it.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tools/args.h"

namespace cairn::tools {
namespace {

std::vector<std::string> Take(std::vector<std::string> args, GlobalOptions* g) {
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  int argc = static_cast<int>(args.size());
  TakeGlobalOptions(&argc, argv.data(), g);
  EXPECT_EQ(argv[argc], nullptr);
  return std::vector<std::string>(argv.begin(), argv.begin() + argc);
}

using V = std::vector<std::string>;

TEST(GlobalOptions, TakenAnywhereBeforeDoubleDash) {
  GlobalOptions g;
  EXPECT_EQ(Take({"cairn", "optimize", "--verbose", "in.g2o", "-o", "x", "--keep-unknown"}, &g),
            (V{"cairn", "optimize", "in.g2o", "-o", "x"}));
  EXPECT_TRUE(g.verbose);
  EXPECT_TRUE(g.keep_unknown);
  GlobalOptions h;
  EXPECT_EQ(Take({"cairn", "info", "--", "--verbose"}, &h), (V{"cairn", "info", "--", "--verbose"}));
  EXPECT_FALSE(h.verbose);
}

TEST(GlobalOptions, ListedInEveryHelp) {
  ArgParser p("demo FILE", "A demo.");
  EXPECT_NE(p.Help().find("--verbose"), std::string::npos);
  EXPECT_NE(p.Help().find("--keep-unknown"), std::string::npos);
}

}  // namespace
}  // namespace cairn::tools
