// The pieces of a sparse Cholesky analysis that work on the pose graph's
// block structure (one dense diagonal block per pose) rather than on scalar
// unknowns, shared by the CHOLMOD back-ends in sparse_cholesky.cpp and
// domain_cholesky.cpp. Internal to backend/.
#pragma once

#include <cholmod.h>

#include <vector>

namespace cairn {

// The block graph of an upper-triangular scalar pattern (compressed
// columns, rows sorted): first[b] is the first scalar unknown of block b;
// column b of (bp, bi) lists the blocks b' <= b it couples to, b included.
struct BlockPattern {
  std::vector<int> first, bp, bi;
  int blocks() const { return static_cast<int>(first.size()) - 1; }
};

// Throws std::invalid_argument when the block sizes do not add up to n.
BlockPattern MakeBlockPattern(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
                              const std::vector<int>& block_sizes);

// The block graph as a CHOLMOD pattern matrix (upper triangle), for its
// orderings; null when out of memory. The caller frees it.
cholmod_sparse* BlockGraph(const BlockPattern& pattern, cholmod_common* common);

// Graphs of at least this many blocks are also ordered by nested dissection
// (METIS through CHOLMOD), and its order is taken when its factor costs fewer
// flops than AMD's. Below it METIS's own time outweighs the saving: on a
// simulated 2D graph of 100,000 poses it cut the factor's flops by 30% but
// took as long as a factorisation; at a million poses it halves them.
constexpr int kNestedDissectionMinBlocks = 250000;

// A fill-reducing order of the block graph: AMD, or on large graphs the
// cheaper of AMD and nested dissection; empty when CHOLMOD fails.
std::vector<int> FillReducingBlockOrder(const BlockPattern& pattern, cholmod_common* common,
                                        int nested_dissection_min_blocks = kNestedDissectionMinBlocks);

// Flops of the block graph's Cholesky factor in `order` (CHOLMOD's symbolic
// analysis; infinite when it fails): the scalar factor's are these times
// about the block size cubed, whatever the order.
double BlockFactorFlops(const BlockPattern& pattern, std::vector<int>* order,
                        cholmod_common* common);

// The blocks with side[b] == s, ordered by nested dissection (METIS) of
// the graph they induce; empty when METIS fails or there are none.
std::vector<int> SideNestedDissection(const BlockPattern& pattern, const std::vector<int>& side,
                                      int s, cholmod_common* common);

// The block ordering followed by a postorder of the block graph's
// elimination tree in it: each subtree's blocks, hence each supernode's
// columns, become contiguous, as CHOLMOD's own analysis would order them
// (it postorders the scalar tree, which within a block is a chain). Same
// fill, and the symbolic factorisation then needs no ordering of its own.
// `parent`, if given, receives the tree: the parent of the block at
// position k of the result, by position (-1 for a root).
std::vector<int> Postordered(const std::vector<int>& order, const BlockPattern& pattern,
                             std::vector<int>* parent = nullptr);

// A block permutation expanded to the scalar unknowns.
std::vector<int> ExpandBlocks(const std::vector<int>& block_perm, const BlockPattern& pattern);

// The entries of the upper-triangular pattern (col_ptr, rows) whose row and
// column both have a place (`local[i]` >= 0), laid out as an m x m matrix in
// the triangle asked for, rows sorted: what CHOLMOD factorises without a
// copy (the supernodal method reads the lower triangle, the simplicial the
// upper). scatter[k] receives where entry k's value goes, or -1.
cholmod_sparse* LocalPattern(const std::vector<int>& col_ptr, const std::vector<int>& rows,
                             const std::vector<int>& local, int m, bool upper,
                             std::vector<int>* scatter, cholmod_common* common);

// Nonzeros of a supernodal factor's L (each supernode's trapezoid).
long SupernodalNonZeros(const cholmod_factor* factor);

}  // namespace cairn
