#include "cairn/graph/text_input.h"

#include <algorithm>
#include <cstring>
#include <istream>
#include <stdexcept>


namespace cairn {

ParseError::ParseError(const std::string& file, size_t line, const std::string& message)
    : std::runtime_error(file + ":" + std::to_string(line) + ": " + message),
      file_(file),
      line_(line),
      message_(message) {}
namespace {

constexpr size_t kChunk = size_t{1} << 16;
constexpr char kBom[] = "\xEF\xBB\xBF";

}  // namespace

TextInput::TextInput(std::istream& in, std::string name, size_t max_line_bytes)
    : TextInput(
          [&in](char* buf, size_t n) -> size_t {
            in.read(buf, static_cast<std::streamsize>(n));
            if (in.bad()) throw std::runtime_error("read error");
            return static_cast<size_t>(in.gcount());
          },
          std::move(name), max_line_bytes) {}

TextInput::TextInput(Source source, std::string name, size_t max_line_bytes)
    : source_(std::move(source)), name_(std::move(name)), max_line_(max_line_bytes) {}

// Moves the unread bytes to the front and reads more behind them. The
// buffer never grows beyond a line's bound and one chunk.
bool TextInput::Fill() {
  if (at_end_) return false;
  if (begin_ > 0) {
    std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  if (buf_.size() < end_ + kChunk) buf_.resize(end_ + kChunk);
  size_t got = 0;
  try {
    got = source_(buf_.data() + end_, kChunk);
  } catch (const std::exception& e) {
    throw ParseError(name_, line_ + 1, e.what());
  }
  if (got == 0) {
    at_end_ = true;
    return false;
  }
  end_ += got;
  return true;
}

bool TextInput::Next(std::string* line) {
  size_t scanned = 0;  // bytes of the current line known to hold no '\n'
  for (;;) {
    // A byte-order mark is decided on once three bytes (or the end) are in.
    if (at_start_ && (end_ - begin_ >= 3 || at_end_)) {
      if (end_ - begin_ >= 3 && std::memcmp(buf_.data() + begin_, kBom, 3) == 0) begin_ += 3;
      at_start_ = false;
    }
    const size_t avail = end_ - begin_;
    if (!at_start_) {
      const char* start = buf_.data() + begin_;
      const void* nl = avail > scanned ? std::memchr(start + scanned, '\n', avail - scanned) : nullptr;
      const size_t length = nl ? static_cast<size_t>(static_cast<const char*>(nl) - start) : avail;
      if (length > max_line_) throw ParseError(name_, line_ + 1, TooLong());
      if (nl) return Take(length, length + 1, line);
      scanned = avail;
    }
    if (!Fill()) {
      if (at_start_) continue;
      if (end_ == begin_) return false;
      return Take(end_ - begin_, end_ - begin_, line);
    }
  }
}

bool TextInput::Take(size_t length, size_t consumed, std::string* line) {
  const char* start = buf_.data() + begin_;
  if (length > 0 && start[length - 1] == '\r') --length;
  line->assign(start, length);
  begin_ += consumed;
  ++line_;
  return true;
}

std::string TextInput::TooLong() const {
  return "line longer than " + std::to_string(max_line_) + " bytes";
}

}  // namespace cairn
