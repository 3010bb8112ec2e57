// A loop closure named by its two vertex ids, as the robustness tools add,
// reject and list them.
#pragma once

#include <cstdint>
#include <utility>

namespace cairn {

using VertexPair = std::pair<int64_t, int64_t>;

}  // namespace cairn
