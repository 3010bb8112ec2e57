// Writing output files so that a reader never sees half of one: every
// writer of cairn's (graphs, reports, plots, maps) goes through here.
#pragma once

#include <functional>
#include <iosfwd>
#include <string>

namespace cairn {

// Writes a file atomically: `fill` writes to a temporary stream, which is
// renamed onto `path` only if `fill` returns without throwing.
void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& fill);

}  // namespace cairn
