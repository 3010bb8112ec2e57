#include "cairn/linear/block_ordering.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace cairn {

BlockPattern MakeBlockPattern(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
                              const std::vector<int>& block_sizes) {
  BlockPattern p;
  const int nb = static_cast<int>(block_sizes.size());
  p.first.assign(nb + 1, 0);
  for (int b = 0; b < nb; ++b) p.first[b + 1] = p.first[b] + block_sizes[b];
  if (p.first[nb] != n) throw std::invalid_argument("block sizes do not add up to the matrix size");
  std::vector<int> block_of(n);
  for (int b = 0; b < nb; ++b)
    for (int i = p.first[b]; i < p.first[b + 1]; ++i) block_of[i] = b;
  // The last scalar column of a block holds every block row it touches.
  p.bp.assign(nb + 1, 0);
  for (int b = 0; b < nb; ++b) {
    const int col = p.first[b + 1] - 1;
    int last = -1;
    for (int k = col_ptr[col]; k < col_ptr[col + 1]; ++k) {
      const int rb = block_of[rows[k]];
      if (rb != last) p.bi.push_back(last = rb);
    }
    p.bp[b + 1] = static_cast<int>(p.bi.size());
  }
  return p;
}

namespace {

// BlockFactorFlops on the block graph as CHOLMOD holds it.
double GraphFactorFlops(cholmod_sparse* graph, std::vector<int>* order, cholmod_common* common) {
  const int saved_methods = common->nmethods, saved_ordering = common->method[0].ordering;
  const int saved_super = common->supernodal, saved_post = common->postorder;
  common->nmethods = 1;
  common->method[0].ordering = CHOLMOD_GIVEN;
  common->supernodal = CHOLMOD_SIMPLICIAL;
  common->postorder = 0;
  cholmod_factor* f = cholmod_analyze_p(graph, order->data(), nullptr, 0, common);
  const double flops = f ? common->fl : std::numeric_limits<double>::infinity();
  if (f) cholmod_free_factor(&f, common);
  common->nmethods = saved_methods;
  common->method[0].ordering = saved_ordering;
  common->supernodal = saved_super;
  common->postorder = saved_post;
  return flops;
}

}  // namespace

cholmod_sparse* BlockGraph(const BlockPattern& pattern, cholmod_common* common) {
  const int nb = pattern.blocks();
  cholmod_sparse* graph =
      cholmod_allocate_sparse(nb, nb, pattern.bi.size(), 1, 1, 1, CHOLMOD_PATTERN, common);
  if (!graph) return nullptr;
  std::memcpy(graph->p, pattern.bp.data(), sizeof(int) * (nb + 1));
  std::memcpy(graph->i, pattern.bi.data(), sizeof(int) * pattern.bi.size());
  return graph;
}

double BlockFactorFlops(const BlockPattern& pattern, std::vector<int>* order,
                        cholmod_common* common) {
  cholmod_sparse* graph = BlockGraph(pattern, common);
  if (!graph) return std::numeric_limits<double>::infinity();
  const double flops = GraphFactorFlops(graph, order, common);
  cholmod_free_sparse(&graph, common);
  return flops;
}

namespace {

// The graph that the blocks with side[b] == s induce, numbered in
// increasing block order (so that it stays upper triangular); `blocks`
// receives each local block's global one. Null when out of memory.
cholmod_sparse* SideGraph(const BlockPattern& pattern, const std::vector<int>& side, int s,
                          std::vector<int>* blocks, cholmod_common* common) {
  const int nb = pattern.blocks();
  std::vector<int> local(nb, -1);
  blocks->clear();
  for (int b = 0; b < nb; ++b)
    if (side[b] == s) local[b] = static_cast<int>(blocks->size()), blocks->push_back(b);
  std::vector<int> p(1, 0), i;
  for (int b : *blocks) {
    for (int k = pattern.bp[b]; k < pattern.bp[b + 1]; ++k)
      if (local[pattern.bi[k]] >= 0) i.push_back(local[pattern.bi[k]]);
    p.push_back(static_cast<int>(i.size()));
  }
  const int m = static_cast<int>(blocks->size());
  cholmod_sparse* g = cholmod_allocate_sparse(m, m, i.size(), 1, 1, 1, CHOLMOD_PATTERN, common);
  if (!g) return nullptr;
  std::memcpy(g->p, p.data(), sizeof(int) * p.size());
  if (!i.empty()) std::memcpy(g->i, i.data(), sizeof(int) * i.size());
  return g;
}

}  // namespace

std::vector<int> SideNestedDissection(const BlockPattern& pattern, const std::vector<int>& side,
                                      int s, cholmod_common* common) {
  std::vector<int> blocks;
  cholmod_sparse* g = SideGraph(pattern, side, s, &blocks, common);
  if (!g) return {};
  std::vector<int> nd(blocks.size());
  const bool ok = !blocks.empty() && cholmod_metis(g, nullptr, 0, /*postorder=*/0, nd.data(), common);
  cholmod_free_sparse(&g, common);
  if (!ok) return {};
  for (int& k : nd) k = blocks[k];
  return nd;
}

std::vector<int> FillReducingBlockOrder(const BlockPattern& pattern, cholmod_common* common,
                                        int nested_dissection_min_blocks) {
  cholmod_sparse* graph = BlockGraph(pattern, common);
  if (!graph) return {};
  std::vector<int> order(pattern.blocks());
  int ok = cholmod_amd(graph, nullptr, 0, order.data(), common);
  if (ok && pattern.blocks() >= nested_dissection_min_blocks) {
    std::vector<int> nd(pattern.blocks());
    if (cholmod_metis(graph, nullptr, 0, /*postorder=*/0, nd.data(), common)) {
      const double amd_flops = GraphFactorFlops(graph, &order, common);
      const double nd_flops = GraphFactorFlops(graph, &nd, common);
      if (nd_flops < amd_flops) order.swap(nd);
    }
  }
  cholmod_free_sparse(&graph, common);
  if (!ok) return {};
  return order;
}

std::vector<int> Postordered(const std::vector<int>& order, const BlockPattern& pattern,
                             std::vector<int>* parent_out) {
  const std::vector<int>& bp = pattern.bp;
  const std::vector<int>& bi = pattern.bi;
  const int nb = static_cast<int>(order.size());
  std::vector<int> inverse(nb);
  for (int k = 0; k < nb; ++k) inverse[order[k]] = k;
  // Upper triangle of the permuted block pattern, by column.
  std::vector<int> start(nb + 1, 0);
  for (int b = 0; b < nb; ++b)
    for (int k = bp[b]; k < bp[b + 1]; ++k)
      if (bi[k] != b) ++start[std::max(inverse[bi[k]], inverse[b]) + 1];
  for (int j = 0; j < nb; ++j) start[j + 1] += start[j];
  std::vector<int> above(start[nb]), next(start.begin(), start.end() - 1);
  for (int b = 0; b < nb; ++b)
    for (int k = bp[b]; k < bp[b + 1]; ++k)
      if (bi[k] != b) {
        const int i = inverse[bi[k]], j = inverse[b];
        above[next[std::max(i, j)]++] = std::min(i, j);
      }
  // Liu's algorithm, with path compression through `ancestor`.
  std::vector<int> parent(nb, -1), ancestor(nb, -1);
  for (int j = 0; j < nb; ++j)
    for (int t = start[j]; t < start[j + 1]; ++t)
      for (int i = above[t]; i != -1 && i < j;) {
        const int up = ancestor[i];
        ancestor[i] = j;
        if (up == -1) parent[i] = j;
        i = up;
      }
  // Children in increasing order, then depth-first from each root.
  std::vector<int> head(nb, -1), sibling(nb, -1);
  for (int j = nb - 1; j >= 0; --j)
    if (parent[j] != -1) sibling[j] = head[parent[j]], head[parent[j]] = j;
  std::vector<int> post, position(nb), stack;
  post.reserve(nb);
  for (int root = 0; root < nb; ++root) {
    if (parent[root] != -1) continue;
    stack.push_back(root);
    while (!stack.empty()) {
      const int j = stack.back();
      if (head[j] != -1) {
        const int child = head[j];
        head[j] = sibling[child];
        stack.push_back(child);
      } else {
        stack.pop_back();
        position[j] = static_cast<int>(post.size());
        post.push_back(order[j]);
      }
    }
  }
  if (parent_out) {
    parent_out->assign(nb, -1);
    for (int j = 0; j < nb; ++j)
      if (parent[j] != -1) (*parent_out)[position[j]] = position[parent[j]];
  }
  return post;
}

std::vector<int> ExpandBlocks(const std::vector<int>& block_perm, const BlockPattern& pattern) {
  std::vector<int> perm;
  perm.reserve(pattern.first.back());
  for (int b : block_perm)
    for (int i = pattern.first[b]; i < pattern.first[b + 1]; ++i) perm.push_back(i);
  return perm;
}

cholmod_sparse* LocalPattern(const std::vector<int>& col_ptr, const std::vector<int>& rows,
                             const std::vector<int>& local, int m, bool upper,
                             std::vector<int>* scatter, cholmod_common* common) {
  const int n = static_cast<int>(col_ptr.size()) - 1;
  const size_t nnz = rows.size();
  // Entry k of the pattern (row rows[k] of column j) lands at (*row, *col).
  auto place = [&](int k, int j, int* row, int* col) {
    const int li = local[rows[k]], lj = local[j];
    if (li < 0 || lj < 0) return false;
    *row = upper ? std::min(li, lj) : std::max(li, lj);
    *col = upper ? std::max(li, lj) : std::min(li, lj);
    return true;
  };
  // Counting sort by row, then stably by column: rows sorted in columns.
  std::vector<int> row_start(m + 1, 0);
  int r, c;
  size_t kept = 0;
  for (int j = 0; j < n; ++j)
    for (int k = col_ptr[j]; k < col_ptr[j + 1]; ++k)
      if (place(k, j, &r, &c)) ++row_start[r + 1], ++kept;
  for (int i = 0; i < m; ++i) row_start[i + 1] += row_start[i];
  std::vector<int> next(row_start.begin(), row_start.end() - 1), by_row(kept);
  scatter->assign(nnz, -1);  // first the column of each entry, then its place
  for (int j = 0; j < n; ++j)
    for (int k = col_ptr[j]; k < col_ptr[j + 1]; ++k)
      if (place(k, j, &r, &c)) {
        by_row[next[r]++] = k;
        (*scatter)[k] = c;
      }
  std::vector<int> col_start(m + 1, 0);
  for (size_t k = 0; k < nnz; ++k)
    if ((*scatter)[k] >= 0) ++col_start[(*scatter)[k] + 1];
  for (int i = 0; i < m; ++i) col_start[i + 1] += col_start[i];
  cholmod_sparse* a = cholmod_allocate_sparse(m, m, kept, /*sorted=*/1, /*packed=*/1,
                                              upper ? 1 : -1, CHOLMOD_REAL, common);
  if (!a) throw std::runtime_error("CHOLMOD: out of memory allocating the normal matrix");
  std::memcpy(a->p, col_start.data(), sizeof(int) * (m + 1));
  int* ai = static_cast<int*>(a->i);
  for (int row = 0; row < m; ++row)
    for (int t = row_start[row]; t < row_start[row + 1]; ++t) {
      const int k = by_row[t];
      const int at = col_start[(*scatter)[k]]++;
      ai[at] = row;
      (*scatter)[k] = at;
    }
  std::memset(a->x, 0, sizeof(double) * kept);
  return a;
}

long SupernodalNonZeros(const cholmod_factor* factor) {
  long nz = 0;
  const int* super = static_cast<const int*>(factor->super);
  const int* pi = static_cast<const int*>(factor->pi);
  for (size_t s = 0; s < factor->nsuper; ++s) {
    const long cols = super[s + 1] - super[s], rows = pi[s + 1] - pi[s];
    nz += cols * rows - cols * (cols - 1) / 2;
  }
  return nz;
}

}  // namespace cairn
