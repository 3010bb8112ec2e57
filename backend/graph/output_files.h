// Writing output files so that a reader never sees half of one, and so that
// a command's outputs appear all together or not at all: every writer of
// cairn's (graphs, reports, plots, maps) goes through here.
#pragma once

#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace cairn {

// Writes one file safely: `fill` writes to a temporary file created
// exclusively (an unpredictable name, never through a symlink) beside the
// target, which is flushed to disk and renamed onto `path` only if `fill`
// returns without throwing; the target keeps its permissions. A symlink is
// followed (the link stays a link); a device or FIFO is written in place.
// Errors are std::runtime_error, "PATH: what went wrong (reason)".
void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& fill);

// A command's outputs, all or nothing. Declare every output and input first
// and Check() before any work: it refuses outputs that are the same file as
// each other or as an input, a missing or unwritable directory, an output
// that is a directory. Write() each output to its temporary; Commit() puts
// them all in place. Any failure (or destruction without Commit) removes the
// temporaries and leaves every target as it was. An output declared but
// never written is left alone by Commit.
//
//   OutputSet outputs;
//   outputs.AddInput(in);
//   outputs.AddOutput(out);
//   if (!report.empty()) outputs.AddOutput(report);
//   outputs.Check();
//   ... the work ...
//   outputs.Write(out, [&](std::ostream& os) { WriteG2o(graph, os); });
//   outputs.Write(report, [&](std::ostream& os) { os << text; });
//   outputs.Commit();
class OutputSet {
 public:
  OutputSet();
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  void AddInput(const std::string& path);
  void AddOutput(const std::string& path);
  // Throws std::runtime_error naming the paths at fault. Write and Commit
  // run it first if it has not been run.
  void Check();
  // Writes a declared output to its temporary (devices and FIFOs: to
  // memory, written at Commit). On failure discards the whole set and
  // rethrows.
  void Write(const std::string& path, const std::function<void(std::ostream&)>& fill);
  // In-place outputs first, then the renames, then the directories synced.
  void Commit();
  // Removes every temporary; no target changes. Safe to call twice.
  void Discard() noexcept;

 private:
  struct Output;
  void Abandon() noexcept;
  std::vector<std::string> inputs_;
  std::vector<std::unique_ptr<Output>> outputs_;
  bool checked_ = false, failed_ = false, committed_ = false;
};

// For tests: the names tried for temporaries (attempt 0, 1, ...), to plant
// files where they will be created. Empty restores the random names.
void SetTemporaryNamesForTesting(std::function<std::string(int attempt)> names);

}  // namespace cairn
