// Line-by-line reading of a text input, the same for every reader cairn has
// (g2o/TORO, CARMEN logs, trajectories, calibration pairs): a UTF-8
// byte-order mark at the start is skipped, lines are counted for FILE:LINE
// errors, and a line longer than a bound is refused instead of buffered
// without end (a binary file or /dev/zero fails fast, in bounded memory).
#pragma once

#include <cstddef>
#include <functional>
#include <iosfwd>
#include <stdexcept>
#include <string>
#include <vector>

namespace cairn {

// A malformed input: what() reads "FILE:LINE: what is wrong".
class ParseError : public std::runtime_error {
 public:
  ParseError(const std::string& file, size_t line, const std::string& message);
  const std::string& file() const { return file_; }
  size_t line() const { return line_; }
  const std::string& message() const { return message_; }

 private:
  std::string file_;
  size_t line_;
  std::string message_;
};

// Far above any real line (a 100000-beam laser scan is about 700 KB).
inline constexpr size_t kDefaultMaxLineBytes = size_t{1} << 20;

// The sane ranges the readers hold a pose's numbers to. A heading beyond
// kMaxAbsAngle rad (160 turns) is a corrupt field, not an angle: the
// solvers' trigonometry loses all its digits there, and one solver fails
// where the other "converges". A coordinate beyond kMaxAbsCoordinate m has
// no millimetres left in a double, and its square overflows long before 1e300.
inline constexpr double kMaxAbsAngle = 1e3;
inline constexpr double kMaxAbsCoordinate = 1e9;

class TextInput {
 public:
  // Reads up to n bytes into buf and returns how many, 0 at the end of the
  // input; throws on a read error.
  using Source = std::function<size_t(char* buf, size_t n)>;

  // `name` is the file name errors give. The stream must outlive this.
  TextInput(std::istream& in, std::string name, size_t max_line_bytes = kDefaultMaxLineBytes);
  TextInput(Source source, std::string name, size_t max_line_bytes = kDefaultMaxLineBytes);

  // The next line, without its '\n' (nor a '\r' before it); false at the end
  // of the input. A last line without '\n' is still a line. Throws
  // ParseError "NAME:LINE: line longer than N bytes", or "read error".
  bool Next(std::string* line);

  // The number of the line Next returned last (1-based; 0 before the first).
  size_t line() const { return line_; }
  const std::string& name() const { return name_; }
  size_t max_line_bytes() const { return max_line_; }

 private:
  bool Fill();
  bool Take(size_t length, size_t consumed, std::string* line);
  std::string TooLong() const;

  Source source_;
  std::string name_;
  size_t max_line_;
  std::vector<char> buf_;
  size_t begin_ = 0, end_ = 0;  // unread bytes are buf_[begin_, end_)
  size_t line_ = 0;
  bool at_start_ = true;
  bool at_end_ = false;
};

}  // namespace cairn
