#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "cairn/linear/spill_file.h"

namespace cairn {
namespace {

std::filesystem::path FreshDir() {
  std::string name = (std::filesystem::temp_directory_path() / "cairn-spill-test-XXXXXX").string();
  std::vector<char> path(name.begin(), name.end());
  path.push_back('\0');
  EXPECT_NE(mkdtemp(path.data()), nullptr);
  return path.data();
}

// Arrays written at their offsets read back as written, and the file has
// no name in the directory, not even while it is open.
TEST(SpillFile, ReadsBackWhatItWroteAndLeavesNoName) {
  const std::filesystem::path dir = FreshDir();
  {
    SpillFile file(dir.string());
    ASSERT_TRUE(file.ok());
    EXPECT_EQ(file.dir(), dir.string());
    std::vector<double> first(1000), second(3);
    for (size_t i = 0; i < first.size(); ++i) first[i] = 0.5 * i - 7;
    second = {1e300, -0.0, 3.25};
    ASSERT_TRUE(file.Write(0, first.data(), first.size()));
    ASSERT_TRUE(file.Write(first.size() * sizeof(double), second.data(), second.size()));
    EXPECT_TRUE(std::filesystem::is_empty(dir));
    std::vector<double> back(second.size()), front(first.size());
    ASSERT_TRUE(file.Read(first.size() * sizeof(double), back.data(), back.size()));
    ASSERT_TRUE(file.Read(0, front.data(), front.size()));
    EXPECT_EQ(back, second);
    EXPECT_EQ(front, first);
    // Past its end there is nothing to read.
    EXPECT_FALSE(file.Read(1 << 20, back.data(), back.size()));
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  std::filesystem::remove(dir);
}

TEST(SpillFile, NotMadeWhereThereIsNoDirectory) {
  SpillFile file("/nonexistent-cairn-spill-dir");
  EXPECT_FALSE(file.ok());
}

// Without a directory named: $TMPDIR.
TEST(SpillFile, UsesTmpdir) {
  const std::filesystem::path dir = FreshDir();
  const char* saved = std::getenv("TMPDIR");
  const std::string kept = saved ? saved : "";
  setenv("TMPDIR", dir.c_str(), 1);
  SpillFile file;
  if (saved) setenv("TMPDIR", kept.c_str(), 1); else unsetenv("TMPDIR");
  EXPECT_TRUE(file.ok());
  EXPECT_EQ(file.dir(), dir.string());
  std::filesystem::remove(dir);
}

}  // namespace
}  // namespace cairn
