// The one line reader under every text input: byte-order marks, line
// numbers, line ends, and a bound on a line's length that holds on a
// stream with no newline at all.
#include <gtest/gtest.h>

#include <sstream>
#include <streambuf>
#include <string>
#include <vector>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/text_input.h"

namespace cairn {
namespace {

std::vector<std::string> Lines(const std::string& text, size_t max_line = kDefaultMaxLineBytes) {
  std::istringstream in(text);
  TextInput input(in, "t.txt", max_line);
  std::vector<std::string> out;
  std::string line;
  while (input.Next(&line)) {
    out.push_back(line);
    EXPECT_EQ(input.line(), out.size());
  }
  return out;
}

using V = std::vector<std::string>;

TEST(TextInput, LinesAndLineEnds) {
  EXPECT_EQ(Lines("a\nb c\n"), (V{"a", "b c"}));
  EXPECT_EQ(Lines("a\r\nb\r\n"), (V{"a", "b"}));
  EXPECT_EQ(Lines("a\n\nlast"), (V{"a", "", "last"}));
  EXPECT_EQ(Lines(""), V{});
  EXPECT_EQ(Lines("\n"), V{""});
  EXPECT_EQ(Lines("x"), V{"x"});
}

TEST(TextInput, SkipsAByteOrderMarkAtTheStartOnly) {
  EXPECT_EQ(Lines("\xEF\xBB\xBFVERTEX_SE2 0 0 0 0\n"), V{"VERTEX_SE2 0 0 0 0"});
  EXPECT_EQ(Lines("\xEF\xBB\xBF"), V{});
  EXPECT_EQ(Lines("\xEF\xBB\xBF\n"), V{""});
  // Not at the start: data, left for the reader to judge.
  EXPECT_EQ(Lines("a\n\xEF\xBB\xBF" "b\n"), (V{"a", "\xEF\xBB\xBF" "b"}));
  // A prefix of one is not one.
  EXPECT_EQ(Lines("\xEF\xBB"), V{"\xEF\xBB"});
}

TEST(TextInput, ReadsSmallChunksAcrossLines) {
  const std::string text = "\xEF\xBB\xBF" "first\nsecond line\r\n\nthird";
  size_t pos = 0;
  TextInput input(
      [&](char* buf, size_t n) -> size_t {
        if (pos == text.size() || n == 0) return 0;
        buf[0] = text[pos++];
        return 1;
      },
      "chunks.txt");
  std::vector<std::string> got;
  std::string line;
  while (input.Next(&line)) got.push_back(line);
  EXPECT_EQ(got, (V{"first", "second line", "", "third"}));
}

TEST(TextInput, RefusesALineLongerThanTheBound) {
  EXPECT_EQ(Lines(std::string(10, 'x') + "\n", 10), V{std::string(10, 'x')});
  try {
    Lines("ok\n" + std::string(11, 'x') + "\nmore\n", 10);
    ADD_FAILURE() << "no error";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), 2u);
    EXPECT_STREQ(e.what(), "t.txt:2: line longer than 10 bytes");
  }
  // The same without the newline, at the end of the input.
  EXPECT_THROW(Lines(std::string(11, 'x'), 10), ParseError);
}

// NUL bytes without end, like /dev/zero, counting what was taken from it.
class Zeros : public std::streambuf {
 public:
  size_t served() const { return served_; }

 protected:
  int_type underflow() override {
    std::fill(std::begin(buf_), std::end(buf_), '\0');
    setg(buf_, buf_, buf_ + sizeof buf_);
    served_ += sizeof buf_;
    return traits_type::to_int_type(buf_[0]);
  }

 private:
  char buf_[4096];
  size_t served_ = 0;
};

TEST(TextInput, AStreamOfNulBytesFailsFastInBoundedMemory) {
  Zeros zeros;
  std::istream in(&zeros);
  TextInput input(in, "zeros");
  std::string line;
  try {
    input.Next(&line);
    ADD_FAILURE() << "no error";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), 1u);
    EXPECT_EQ(e.message(), "line longer than 1048576 bytes");
  }
  // Read no further than the bound and a chunk.
  EXPECT_LE(zeros.served(), kDefaultMaxLineBytes + (size_t{1} << 17));
}

TEST(TextInput, TheGraphReaderStopsOnTheNulStream) {
  Zeros zeros;
  std::istream in(&zeros);
  try {
    ReadGraph(in, "zeros.g2o");
    ADD_FAILURE() << "no error";
  } catch (const ParseError& e) {
    EXPECT_STREQ(e.what(), "zeros.g2o:1: line longer than 1048576 bytes");
  }
  ReadOptions small;
  small.max_line_bytes = 100;
  Zeros more;
  std::istream in2(&more);
  EXPECT_THROW(ReadGraph(in2, "zeros.g2o", small), ParseError);
  EXPECT_LE(more.served(), size_t{1} << 17);
}

}  // namespace
}  // namespace cairn
