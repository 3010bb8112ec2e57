// The tool's own parsing helpers (tools/args.h), compiled into this suite.
#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "tools/args.h"

namespace cairn::tools {
namespace {

TEST(Args, ParseIdListReadsCommaSeparatedIds) {
  EXPECT_EQ(ParseIdList("3,17,42"), (std::vector<int64_t>{3, 17, 42}));
  EXPECT_EQ(ParseIdList("-1"), (std::vector<int64_t>{-1}));
  EXPECT_THROW(ParseIdList("3,,4"), std::invalid_argument);
  EXPECT_THROW(ParseIdList("3,"), std::invalid_argument);
  EXPECT_THROW(ParseIdList("x"), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::tools
