// The sparse Cholesky factorisation on two cores: the pose graph is cut at
// a small separator (METIS's node bisection of the block graph; for an
// order kept from an earlier analysis, the top of its elimination tree), the
// two halves are factorised at once by two CHOLMOD instances, and the
// separator (no edge joins the halves but through it) is finished as a
// small dense matrix.
//
// With the separator's unknowns T ordered last,
//   H = [A1 0 B1; 0 A2 B2; B1' B2' C],
// and each half's factor also taken over T, from the principal submatrix
//   M_g = [A_g B_g; B_g' C] = L_g L_g'  with  L_g = [L_gg 0; R_g D_g],
// the bottom-right block gives D_g D_g' = C - B_g' A_g^-1 B_g. The Schur
// complement of the whole is then
//   S = C - B1' A1^-1 B1 - B2' A2^-1 B2 = D1 D1' + D2 D2' - C,
// which is positive definite with H. Each M_g is positive definite too (a
// principal submatrix of H), so CHOLMOD factorises both halves unchanged,
// and the halves' factors keep exactly the fill they have in H's.
// A solve runs forward through both halves at once (L_g y_g = [b_g; 0],
// whose last part gives B_g' A_g^-1 b_g = -D_g y_gT), solves S x_T with the
// dense factor, and back through both halves (L_g' z = [y_g; D_g' x_T]).
#include "cairn/linear/domain_cholesky.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cstring>
#include <exception>
#include <new>
#include <numeric>
#include <stdexcept>

#include "cairn/linear/block_ordering.h"
#include "cairn/linear/cholmod_common.h"
#include "cairn/linear/parallel.h"
#include "cairn/linear/serial_scope.h"
#include "cairn/linear/spill_file.h"

namespace cairn {
namespace {

// Where the graph is cut: the blocks (by position in the postordered
// elimination order) of the top, a separator, and of each half below it.
struct Cut {
  std::vector<int> top, half[2];  // positions, increasing
  double serial = 0, parallel = 0;  // estimated cost, as multiply-adds
};

// The elimination tree's work, estimated per block column from the
// factor's structure: a block column with s unknowns and r rows below its
// diagonal block's top costs about s r^2 multiply-adds.
std::vector<double> ColumnWork(const BlockPattern& pattern, const std::vector<int>& post,
                               const std::vector<int>& parent) {
  const int nb = static_cast<int>(post.size());
  std::vector<int> position(nb);
  for (int k = 0; k < nb; ++k) position[post[k]] = k;
  std::vector<double> rows(nb, 0);
  for (int k = 0; k < nb; ++k) {
    const int b = post[k];
    rows[k] = pattern.first[b + 1] - pattern.first[b];
  }
  // Row k of L reaches, in the elimination tree, every column on the path
  // from each of its nonzeros in A's row up to k (the row subtree).
  std::vector<int> mark(nb, -1);
  std::vector<int> lower_start(nb + 1, 0), lower;
  for (int b = 0; b < nb; ++b)
    for (int t = pattern.bp[b]; t < pattern.bp[b + 1]; ++t) {
      const int i = position[pattern.bi[t]], j = position[b];
      if (i != j) ++lower_start[std::max(i, j) + 1];
    }
  for (int k = 0; k < nb; ++k) lower_start[k + 1] += lower_start[k];
  lower.resize(lower_start[nb]);
  std::vector<int> next(lower_start.begin(), lower_start.end() - 1);
  for (int b = 0; b < nb; ++b)
    for (int t = pattern.bp[b]; t < pattern.bp[b + 1]; ++t) {
      const int i = position[pattern.bi[t]], j = position[b];
      if (i != j) lower[next[std::max(i, j)]++] = std::min(i, j);
    }
  for (int k = 0; k < nb; ++k) {
    mark[k] = k;
    const double size = pattern.first[post[k] + 1] - pattern.first[post[k]];
    for (int t = lower_start[k]; t < lower_start[k + 1]; ++t)
      for (int j = lower[t]; j != -1 && mark[j] != k; j = parent[j]) {
        mark[j] = k;
        rows[j] += size;
      }
  }
  std::vector<double> work(nb);
  for (int k = 0; k < nb; ++k) {
    const double s = pattern.first[post[k] + 1] - pattern.first[post[k]];
    work[k] = s * rows[k] * rows[k];
  }
  return work;
}

// Cuts the tree where two cores should finish soonest: the heaviest
// subtree below the cut is moved into the top until the top's dense cost
// (about its unknowns cubed: each half factorises it, the products D_g D_g'
// and S's factorisation) outweighs the better balance.
Cut PlanCut(const BlockPattern& pattern, const std::vector<int>& post,
            const std::vector<int>& parent) {
  const int nb = static_cast<int>(post.size());
  const std::vector<double> work = ColumnWork(pattern, post, parent);
  std::vector<double> subtree(work);
  std::vector<std::vector<int>> children(nb);
  std::vector<int> roots;
  for (int k = 0; k < nb; ++k) {  // children come before parents in a postorder
    if (parent[k] >= 0) {
      subtree[parent[k]] += subtree[k];
      children[parent[k]].push_back(k);
    } else {
      roots.push_back(k);
    }
  }
  Cut best;
  for (int r : roots) best.serial += subtree[r];
  best.parallel = best.serial;
  std::vector<int> below = roots, top;
  double top_size = 0;
  // At most a top of ~1500 unknowns: beyond, its dense work is the whole.
  for (int step = 0; step < nb && !below.empty() && top_size <= 1500; ++step) {
    // Two groups, heaviest subtree first into the lighter one.
    std::sort(below.begin(), below.end(), [&](int a, int b) { return subtree[a] > subtree[b]; });
    double load[2] = {0, 0};
    std::vector<int> group[2];
    for (int r : below) {
      const int g = load[0] <= load[1] ? 0 : 1;
      load[g] += subtree[r];
      group[g].push_back(r);
    }
    const double cost = std::max(load[0], load[1]) + top_size * top_size * top_size;
    if (!group[0].empty() && !group[1].empty() && cost < best.parallel) {
      best.parallel = cost;
      best.top = top;
      best.half[0] = group[0];
      best.half[1] = group[1];
    }
    // Move the heaviest subtree's root into the top.
    const int heaviest = below.front();
    below.erase(below.begin());
    top.push_back(heaviest);
    top_size += pattern.first[post[heaviest] + 1] - pattern.first[post[heaviest]];
    below.insert(below.end(), children[heaviest].begin(), children[heaviest].end());
  }
  std::sort(best.top.begin(), best.top.end());
  // Each group of subtrees, by their blocks: contiguous in a postorder.
  std::vector<int> size(nb, 1);
  for (int k = 0; k < nb; ++k)
    if (parent[k] >= 0) size[parent[k]] += size[k];
  for (std::vector<int>& half : best.half) {
    std::vector<int> roots;
    roots.swap(half);
    std::sort(roots.begin(), roots.end());
    for (int r : roots)
      for (int p = r - size[r] + 1; p <= r; ++p) half.push_back(p);
  }
  return best;
}

// The cut at a separator found by METIS's node bisection of the block
// graph: CAMD orders each half with the separator last.
bool BisectionOrder(const BlockPattern& pattern, cholmod_common* common, std::vector<int>* order,
                    std::vector<int>* side) {
  const int nb = pattern.blocks();
  cholmod_sparse* graph = BlockGraph(pattern, common);
  if (!graph) return false;
  side->assign(nb, 0);
  order->assign(nb, 0);
  bool ok = cholmod_bisect(graph, nullptr, 0, /*compress=*/1, side->data(), common) >= 0 &&
            common->status == CHOLMOD_OK;
  if (ok) {
    std::vector<int> constraint(nb);
    for (int b = 0; b < nb; ++b) constraint[b] = (*side)[b] == 2 ? 1 : 0;
    ok = cholmod_camd(graph, nullptr, 0, constraint.data(), order->data(), common) &&
         common->status == CHOLMOD_OK;
  }
  cholmod_free_sparse(&graph, common);
  return ok;
}

Cut CutAtSeparator(const BlockPattern& pattern, const std::vector<int>& post,
                   const std::vector<int>& parent, const std::vector<int>& side) {
  const std::vector<double> work = ColumnWork(pattern, post, parent);
  Cut cut;
  double load[3] = {0, 0, 0}, top_size = 0;
  for (size_t p = 0; p < post.size(); ++p) {
    const int s = side[post[p]];
    load[s] += work[p];
    cut.serial += work[p];
    if (s == 2) {
      cut.top.push_back(static_cast<int>(p));
      top_size += pattern.first[post[p] + 1] - pattern.first[post[p]];
    } else {
      cut.half[s].push_back(static_cast<int>(p));
    }
  }
  cut.parallel = std::max(load[0], load[1]) + top_size * top_size * top_size;
  return cut;
}

// One half of the graph with the separator after it, and its factor.
struct Half {
  CholmodCommon common;
  cholmod_sparse* m = nullptr;  // M_g, lower triangle
  cholmod_factor* factor = nullptr;
  cholmod_dense *rhs = nullptr, *forward = nullptr, *backward = nullptr, *ws_y = nullptr,
                *ws_e = nullptr;
  std::vector<int> unknowns;  // unknown of H at each row of M_g: the half's, then T's
  // During Analyze: entry k of H goes to scatter[k] of M_g, or nowhere (-1).
  std::vector<int> scatter;  // freed once from and to hold it
  std::vector<int> from, to;  // the entries that go somewhere: value from[t] of H to to[t]
  int own = 0;                // the half's own unknowns (T's follow)
  Eigen::MatrixXd d, dd;      // D_g, and D_g D_g' (lower)
  bool ok = false;

  ~Half() { Release(); }
  void Release() {
    if (factor) cholmod_free_factor(&factor, common.get());
    if (m) cholmod_free_sparse(&m, common.get());
    for (cholmod_dense** v : {&rhs, &forward, &backward, &ws_y, &ws_e})
      if (*v) cholmod_free_dense(v, common.get());
  }

  // CHOLMOD's choice between its methods, for this half: the simplicial one
  // (kept as LL', so that both read the same way below) on the sparser
  // halves of 2D graphs, the supernodal one on the rest. Each is given the
  // triangle it reads without a copy, as in sparse_cholesky.cpp. CHOLMOD
  // switches to supernodal at 40 flops per nonzero of L; with the coarser
  // supernodes the break-even is nearer 80 (bench_gauss_newton, halves at
  // 47 and 60: simplicial 10.3 ms against supernodal 15.4 on the generated
  // 10,000-pose 2D graph; city10000's at 76 and 85: 20.7 against 20.5;
  // sphere2500's at 214 and 253: supernodal, far ahead).
  static constexpr double kSupernodalSwitch = 80;
  void Analyze(const std::vector<int>& col_ptr, const std::vector<int>& rows,
               const std::vector<int>& local) {
    const int size = static_cast<int>(unknowns.size());
    common->method[0].ordering = CHOLMOD_NATURAL;  // already in elimination order
    common->postorder = 0;
    common->final_ll = 1;
    common->supernodal = CHOLMOD_AUTO;
    common->supernodal_switch = kSupernodalSwitch;
    m = LocalPattern(col_ptr, rows, local, size, /*upper=*/true, &scatter, common.get());
    factor = cholmod_analyze(m, common.get());
    if (factor && factor->is_super) {
      const double nonzeros = common->lnz;
      cholmod_free_factor(&factor, common.get());
      cholmod_free_sparse(&m, common.get());
      m = LocalPattern(col_ptr, rows, local, size, /*upper=*/false, &scatter, common.get());
      common->supernodal = CHOLMOD_SUPERNODAL;
      factor = common.Analyze(m, CholmodCommon::kFineSupernodesMinNonZeros, nonzeros);
    }
    if (!factor) throw std::runtime_error("CHOLMOD: symbolic analysis failed");
    rhs = cholmod_allocate_dense(size, 1, size, CHOLMOD_REAL, common.get());
    // Sized exactly: at a million poses the doubling's slack was 100 MB.
    const size_t used = static_cast<size_t>(
        std::count_if(scatter.begin(), scatter.end(), [](int t) { return t >= 0; }));
    from.reserve(used);
    to.reserve(used);
    for (size_t k = 0; k < scatter.size(); ++k)
      if (scatter[k] >= 0) from.push_back(static_cast<int>(k)), to.push_back(scatter[k]);
    std::vector<int>().swap(scatter);  // at the analysis's peak of memory: not kept twice
  }

  // `values`: H in the caller's layout, or null when written in place.
  void Factorize(const double* values) {
    double* mx = static_cast<double*>(m->x);
    if (values)
      for (size_t t = 0; t < from.size(); ++t) mx[to[t]] = values[from[t]];
    ok = cholmod_factorize(m, factor, common.get()) && common->status == CHOLMOD_OK &&
         factor->minor == factor->n;
    if (ok && !factor->is_ll)
      ok = cholmod_change_factor(CHOLMOD_REAL, /*to_ll=*/1, 0, 1, 1, factor, common.get());
    if (!ok) return;
    // D_g: the separator's columns, the last of the factor.
    const int nt = static_cast<int>(m->nrow) - own;
    d.setZero(nt, nt);
    const double* lx = static_cast<const double*>(factor->x);
    if (factor->is_super) {
      const int* super = static_cast<const int*>(factor->super);
      const int* pi = static_cast<const int*>(factor->pi);
      const int* px = static_cast<const int*>(factor->px);
      const int* ls = static_cast<const int*>(factor->s);
      for (size_t s = 0; s < factor->nsuper; ++s) {
        if (super[s + 1] <= own) continue;
        const int rows = pi[s + 1] - pi[s];
        for (int j = std::max(super[s], own); j < super[s + 1]; ++j) {
          const double* column = lx + px[s] + static_cast<size_t>(j - super[s]) * rows;
          for (int r = j - super[s]; r < rows; ++r) d(ls[pi[s] + r] - own, j - own) = column[r];
        }
      }
    } else {
      const int* lp = static_cast<const int*>(factor->p);
      const int* li = static_cast<const int*>(factor->i);
      const int* lnz = static_cast<const int*>(factor->nz);
      for (int j = own; j < static_cast<int>(factor->n); ++j)
        for (int q = lp[j]; q < lp[j] + lnz[j]; ++q) d(li[q] - own, j - own) = lx[q];
    }
    dd.setZero(nt, nt);
    dd.selfadjointView<Eigen::Lower>().rankUpdate(d);
  }

  // Out of core, the supernodal factor's values live in a buffer the
  // halves share: lent to this half (its factor numeric, the values
  // whatever the buffer holds, to be factorised or read into), or taken
  // back (null: symbolic again, as after the analysis).
  bool Resident() const { return factor && factor->xtype != CHOLMOD_PATTERN; }
  bool Holds(const double* buffer) const { return factor && factor->x == buffer; }
  size_t FactorValues() const { return factor && factor->is_super ? factor->xsize : 0; }
  void Lend(double* buffer) {
    factor->x = buffer;
    factor->xtype = buffer ? CHOLMOD_REAL : CHOLMOD_PATTERN;
    factor->is_ll = 1;
  }

  // Nonzeros of the half's own columns of L (the separator's are S's).
  long OwnNonZeros() const {
    if (!factor) return 0;
    long nz = 0;
    if (factor->is_super) {
      const int* super = static_cast<const int*>(factor->super);
      const int* pi = static_cast<const int*>(factor->pi);
      for (size_t s = 0; s < factor->nsuper; ++s)
        for (int j = super[s]; j < std::min(super[s + 1], own); ++j)
          nz += pi[s + 1] - pi[s] - (j - super[s]);
    } else {
      for (int j = 0; j < own; ++j) nz += static_cast<const int*>(factor->nz)[j];
    }
    return nz;
  }
};

class DomainCholmod final : public SparseCholesky {
 public:
  ~DomainCholmod() override { Release(); }
  DomainCholmod(double min_work, int threads, int nd_min_blocks, double resident_bytes)
      : min_work_(min_work),
        nd_min_blocks_(nd_min_blocks),
        threads_(threads),
        resident_bytes_(resident_bytes) {}

  void Analyze(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
               const std::vector<int>& block_sizes) override {
    Release();
    if (block_sizes.size() < 2) return Whole(n, col_ptr, rows, block_sizes);
    const BlockPattern pattern = MakeBlockPattern(n, col_ptr, rows, block_sizes);
    // A given order (a graph that grew) is cut in its elimination tree;
    // otherwise METIS finds the separator.
    std::vector<int> order, parent, side;
    Cut cut;
    if (static_cast<int>(given_.size()) == pattern.blocks()) {
      used_ = Postordered(given_, pattern, &parent);
      cut = PlanCut(pattern, used_, parent);
    } else if (LittleWork(pattern, &order)) {
      return Whole(n, col_ptr, rows, block_sizes, order);
    } else if (BisectionOrder(pattern, half_[0].common.get(), &order, &side)) {
      if (pattern.blocks() >= nd_min_blocks_) DissectHalves(pattern, side, &order);
      used_ = Postordered(order, pattern, &parent);
      cut = CutAtSeparator(pattern, used_, parent, side);
    }
    if (cut.half[0].empty() || cut.half[1].empty() || cut.serial < min_work_ ||
        cut.parallel > 0.75 * cut.serial)
      return Whole(n, col_ptr, rows, block_sizes);

    std::vector<int> top_index(n, -1);
    for (int p : cut.top)
      for (int i = pattern.first[used_[p]]; i < pattern.first[used_[p] + 1]; ++i) {
        top_index[i] = static_cast<int>(top_.size());
        top_.push_back(i);
      }
    for (int g = 0; g < 2; ++g) {
      Half& h = half_[g];
      for (int p : cut.half[g])
        for (int i = pattern.first[used_[p]]; i < pattern.first[used_[p] + 1]; ++i)
          h.unknowns.push_back(i);
      h.own = static_cast<int>(h.unknowns.size());
      h.unknowns.insert(h.unknowns.end(), top_.begin(), top_.end());
    }
    // The separator's own block C, from the entries both halves share.
    for (int j = 0; j < n; ++j)
      for (int k = col_ptr[j]; k < col_ptr[j + 1]; ++k)
        if (top_index[rows[k]] >= 0 && top_index[j] >= 0)
          c_entries_.push_back({static_cast<size_t>(k), top_index[rows[k]], top_index[j]});
    entries_ = rows.size();
    const int nt = static_cast<int>(top_.size());
    s_.setZero(nt, nt);
    x_top_.setZero(nt);
    for (Eigen::VectorXd& v : through_) v.setZero(nt);
    if (!pool_) pool_ = std::make_unique<ThreadPool>(threads_);
    std::exception_ptr failed[2];
    pool_->ParallelFor(2, [&](size_t begin, size_t end) {
      for (size_t g = begin; g < end; ++g) try {
          Half& h = half_[g];
          std::vector<int> local(n, -1);
          for (size_t t = 0; t < h.unknowns.size(); ++t) local[h.unknowns[t]] = static_cast<int>(t);
          SerialLinearAlgebraScope serial;
          h.Analyze(col_ptr, rows, local);
        } catch (...) {
          failed[g] = std::current_exception();
        }
    }, 1);
    for (const std::exception_ptr& e : failed)
      if (e) std::rethrow_exception(e);
    // The cut is a separator: every entry of H lies in one half or in C.
    std::vector<bool> placed(rows.size(), false);
    for (const Half& h : half_)
      for (int k : h.from) placed[k] = true;
    for (size_t k = 0; k < rows.size(); ++k)
      if (!placed[k])
        throw std::logic_error("domain Cholesky: the cut is not a separator");
    if (OverBudget(pattern)) {
      spill_ = std::make_unique<SpillFile>();
      if (!spill_->ok()) spill_.reset();  // no room on disk: all in memory, as before
    }
  }

  // A graph of at most kLittleWorkMaxBlocks blocks whose factor in AMD's
  // order is below min_work_ stays whole before METIS looks for a
  // separator: on the small shared files the bisection was a third of the
  // set-up (intel: 0.9 of 3.3 ms), and its cut was never taken. `order`
  // receives AMD's order, the one the whole factorisation would make.
  static constexpr int kLittleWorkMaxBlocks = 5000;
  bool LittleWork(const BlockPattern& pattern, std::vector<int>* order) const {
    if (pattern.blocks() > kLittleWorkMaxBlocks) return false;
    CholmodCommon common;
    *order = FillReducingBlockOrder(pattern, common.get());
    if (order->empty()) return false;
    std::vector<int> parent;
    const std::vector<int> post = Postordered(*order, pattern, &parent);
    const std::vector<double> work = ColumnWork(pattern, post, parent);
    if (std::accumulate(work.begin(), work.end(), 0.0) < min_work_) return true;
    order->clear();
    return false;
  }

  // As the single factorisation does (block_ordering.h), large halves are
  // also ordered by nested dissection, and that order is taken when its
  // factor costs fewer flops than CAMD's: at a million 2D poses the halves'
  // factors are most of the solve's memory. One half after the other:
  // METIS draws from one random state for the whole process, so two at
  // once made the orders (and the result's last digits) differ from run to
  // run. The two flop counts are CHOLMOD's own analyses, run at once.
  void DissectHalves(const BlockPattern& pattern, const std::vector<int>& side,
                     std::vector<int>* order) {
    if (!pool_) pool_ = std::make_unique<ThreadPool>(threads_);
    std::vector<int> nd[2];
    for (int g = 0; g < 2; ++g) nd[g] = SideNestedDissection(pattern, side, g, half_[g].common.get());
    if (nd[0].empty() || nd[1].empty()) return;
    std::vector<int> candidate[2] = {std::move(nd[0]), *order};
    candidate[0].insert(candidate[0].end(), nd[1].begin(), nd[1].end());
    for (int b : *order)
      if (side[b] == 2) candidate[0].push_back(b);
    double flops[2];
    pool_->ParallelFor(2, [&](size_t begin, size_t end) {
      for (size_t g = begin; g < end; ++g)
        flops[g] = BlockFactorFlops(pattern, &candidate[g], half_[g].common.get());
    }, 1);
    if (flops[0] < flops[1]) order->swap(candidate[0]);
  }

  bool Extend(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
              const std::vector<int>& block_sizes) override {
    if (whole_) return whole_->Extend(n, col_ptr, rows, block_sizes);
    return false;
  }

  // Made at the first call: a caller that writes in place never needs it.
  double* values() override {
    if (whole_) return whole_->values();
    if (!in_place_ && values_.size() != entries_) values_.assign(entries_, 0.0);
    return values_.data();
  }

  // Each entry goes to the half that holds it; C's, which both halves
  // hold, to the first half's, copied to the second's at each Factorize.
  bool TakeValuesInPlace(ValuePlaces* places) override {
    if (whole_) return whole_->TakeValuesInPlace(places);
    if (in_place_ || !half_[0].m || !half_[1].m) return false;  // taken already, or none
    constexpr uint32_t kNowhere = 0xffffffffu;
    places->index.assign(entries_, kNowhere);
    auto place = [&](int g) {
      const Half& h = half_[g];
      places->arrays[g] = static_cast<double*>(h.m->x);
      for (size_t t = 0; t < h.from.size(); ++t) places->index[h.from[t]] = ValuePlaces::Place(g, h.to[t]);
    };
    place(1);
    c_second_.clear();
    for (const Entry& e : c_entries_) c_second_.push_back(ValuePlaces::Position(places->index[e.k]));
    place(0);
    for (Entry& e : c_entries_) e.k = static_cast<size_t>(ValuePlaces::Position(places->index[e.k]));
    for (uint32_t t : places->index)
      if (t == kNowhere) throw std::logic_error("domain Cholesky: an entry of H has no place");
    std::vector<double>().swap(values_);
    for (Half& h : half_) {
      std::vector<int>().swap(h.from);
      std::vector<int>().swap(h.to);
    }
    in_place_ = true;
    return true;
  }

  bool Factorize() override {
    if (whole_) return whole_->Factorize();
    const double* values = in_place_ ? nullptr : this->values();
    if (in_place_) {
      const double* first = static_cast<const double*>(half_[0].m->x);
      double* second = static_cast<double*>(half_[1].m->x);
      for (size_t c = 0; c < c_entries_.size(); ++c) second[c_second_[c]] = first[c_entries_[c].k];
    }
    SerialLinearAlgebraScope serial;
    if (spill_) {
      if (!FactorizeOutOfCore(values)) return false;
    } else {
      pool_->ParallelFor(2, [&](size_t begin, size_t end) {
        SerialLinearAlgebraScope serial_here;  // OpenMP's setting is per thread
        for (size_t g = begin; g < end; ++g) half_[g].Factorize(values);
      }, 1);
    }
    if (!half_[0].ok || !half_[1].ok) return false;
    if (top_.empty()) return true;
    s_ = half_[0].dd + half_[1].dd;
    // C's entries: in the caller's values, or (in place) in the first half's.
    const double* c_values = in_place_ ? static_cast<const double*>(half_[0].m->x) : values_.data();
    for (const Entry& e : c_entries_) s_(std::max(e.i, e.j), std::min(e.i, e.j)) -= c_values[e.k];
    schur_.compute(s_);
    return schur_.info() == Eigen::Success;
  }

  void Solve(const double* b, double* x) override {
    if (whole_) return whole_->Solve(b, x);
    SerialLinearAlgebraScope serial;
    if (spill_) return SolveOutOfCore(b, x);
    pool_->ParallelFor(2, [&](size_t begin, size_t end) {
      SerialLinearAlgebraScope serial_here;
      for (size_t g = begin; g < end; ++g) Forward(static_cast<int>(g), b);
    }, 1);
    SolveSeparator(b, x);
    pool_->ParallelFor(2, [&](size_t begin, size_t end) {
      SerialLinearAlgebraScope serial_here;
      for (size_t g = begin; g < end; ++g) Backward(static_cast<int>(g), x);
    }, 1);
  }

  long FactorNonZeros() const override {
    if (whole_) return whole_->FactorNonZeros();
    const long nt = static_cast<long>(top_.size());
    return half_[0].OwnNonZeros() + half_[1].OwnNonZeros() + nt * (nt + 1) / 2;
  }
  bool IsSupernodal() const override {
    return whole_ ? whole_->IsSupernodal() : half_[0].factor && half_[0].factor->is_super;
  }
  std::string Method() const override {
    if (whole_) return "not split, " + whole_->Method();
    // An empty problem is never analysed: nothing to factorise.
    if (!half_[0].factor || !half_[1].factor) return "not analysed";
    auto method = [](const Half& h) { return h.factor->is_super ? "supernodal" : "simplicial"; };
    return std::string(spill_ ? "two halves one at a time (" : "two halves at once (") +
           method(half_[0]) + ", " + method(half_[1]) + "), " + std::to_string(top_.size()) +
           " separator unknowns" +
           (spill_ ? ", factors " + std::to_string(FactorBytes() >> 20) +
                         " MiB, the idle half's kept on disk in " + spill_->dir()
                   : "");
  }

  void SetBlockOrdering(const std::vector<int>& block_perm) override { given_ = block_perm; }
  std::vector<int> BlockOrdering() const override {
    return whole_ ? whole_->BlockOrdering() : used_;
  }

 private:
  struct Entry {
    size_t k;
    int i, j;
  };

  // L_g y_g = [b_g; 0], and through_[g] = -B_g' A_g^-1 b_g from y_g's last part.
  void Forward(int g, const double* b) {
    Half& h = half_[g];
    const int nt = static_cast<int>(top_.size());
    double* r = static_cast<double*>(h.rhs->x);
    for (int t = 0; t < h.own; ++t) r[t] = b[h.unknowns[t]];
    std::fill(r + h.own, r + h.own + nt, 0.0);
    cholmod_solve2(CHOLMOD_L, h.factor, h.rhs, nullptr, &h.forward, nullptr, &h.ws_y, &h.ws_e,
                   h.common.get());
    const Eigen::Map<const Eigen::VectorXd> y_top(static_cast<const double*>(h.forward->x) + h.own,
                                                  nt);
    through_[g].noalias() = h.d.triangularView<Eigen::Lower>() * y_top;
  }

  void SolveSeparator(const double* b, double* x) {
    const int nt = static_cast<int>(top_.size());
    for (int t = 0; t < nt; ++t) x_top_[t] = b[top_[t]] + through_[0][t] + through_[1][t];
    if (nt > 0) schur_.solveInPlace(x_top_);
    for (int t = 0; t < nt; ++t) x[top_[t]] = x_top_[t];
  }

  // L_g' z = [y_g; D_g' x_T].
  void Backward(int g, double* x) {
    Half& h = half_[g];
    const int nt = static_cast<int>(top_.size());
    double* r = static_cast<double*>(h.rhs->x);
    std::memcpy(r, h.forward->x, sizeof(double) * h.own);
    Eigen::Map<Eigen::VectorXd>(r + h.own, nt).noalias() =
        h.d.transpose().triangularView<Eigen::Upper>() * x_top_;
    cholmod_solve2(CHOLMOD_Lt, h.factor, h.rhs, nullptr, &h.backward, nullptr, &h.ws_y, &h.ws_e,
                   h.common.get());
    const double* z = static_cast<const double*>(h.backward->x);
    for (int t = 0; t < h.own; ++t) x[h.unknowns[t]] = z[t];
  }

  // Out of core (spill_): at most one half's numeric factor in memory, in
  // one buffer that the halves take in turn (made once: fresh memory costs
  // a page fault per page, every time). The first half is factorised and
  // parked on disk before the second is made; a solve runs forward through
  // the one in memory, parks it, and reads the other back for its whole
  // solve. When a factor cannot be parked (a full disk), both stay in
  // memory from then on: more memory, the same answer.
  bool FactorizeOutOfCore(const double* values) {
    parked_[0] = parked_[1] = false;  // what is on disk is an old factor now
    if (!buffer_) {
      buffer_ = static_cast<double*>(
          cholmod_malloc(BufferValues(), sizeof(double), half_[0].common.get()));
      if (!buffer_) throw std::bad_alloc();
    }
    if (half_[1].Holds(buffer_)) half_[1].Lend(nullptr);
    half_[0].Lend(buffer_);
    half_[0].Factorize(values);
    if (!half_[0].ok) return false;
    Park(0);
    if (spill_) half_[1].Lend(buffer_);  // else CHOLMOD gives it its own
    half_[1].Factorize(values);
    return half_[1].ok;
  }

  void SolveOutOfCore(const double* b, double* x) {
    const int first = half_[1].Resident() ? 1 : 0, second = 1 - first;
    Forward(first, b);
    Park(first);
    Fetch(second);
    Forward(second, b);
    SolveSeparator(b, x);
    Backward(second, x);
    Park(second);
    Fetch(first);
    Backward(first, x);
  }

  // The buffer holds either half's factor.
  size_t BufferValues() const {
    return std::max(half_[0].FactorValues(), half_[1].FactorValues());
  }

  size_t SpillOffset(int g) const { return g == 0 ? 0 : half_[0].FactorValues() * sizeof(double); }

  void Park(int g) {
    Half& h = half_[g];
    if (!spill_ || !h.Resident()) return;
    if (!parked_[g])
      parked_[g] = spill_->Write(SpillOffset(g), static_cast<const double*>(h.factor->x),
                                 h.FactorValues());
    if (parked_[g]) return h.Lend(nullptr);
    // No room on disk: the other half, if parked, back into memory of its own.
    Half& other = half_[1 - g];
    if (!other.Resident() && parked_[1 - g]) {
      if (!cholmod_change_factor(CHOLMOD_REAL, 1, 1, 1, 1, other.factor, other.common.get()))
        throw std::runtime_error("out of memory for a factor that could not be parked on disk");
      Read(1 - g);
    }
    spill_.reset();
  }

  void Fetch(int g) {
    if (!spill_ || half_[g].Resident()) return;
    half_[g].Lend(buffer_);
    Read(g);
  }

  void Read(int g) {
    Half& h = half_[g];
    if (!parked_[g] || !spill_->Read(SpillOffset(g), static_cast<double*>(h.factor->x),
                                     h.FactorValues()))
      throw std::runtime_error("cannot read a factor back from its temporary file in " +
                               spill_->dir());
  }

  size_t FactorBytes() const {
    return sizeof(double) * (half_[0].FactorValues() + half_[1].FactorValues());
  }

  // Both halves' numeric factors over what the graph may hold in memory:
  // kResidentBytesPerPair for each pair of blocks that H joins (each
  // edge's), and at least kResidentFloorBytes.
  bool OverBudget(const BlockPattern& pattern) const {
    if (!half_[0].FactorValues() || !half_[1].FactorValues()) return false;
    const double bytes = static_cast<double>(FactorBytes());
    if (resident_bytes_ >= 0) return bytes > resident_bytes_;
    const double pairs = static_cast<double>(pattern.bi.size()) - pattern.blocks();
    return bytes > std::max(kResidentFloorBytes, kResidentBytesPerPair * pairs);
  }

  void Release() {
    for (Half& h : half_)
      if (buffer_ && h.Holds(buffer_)) h.Lend(nullptr);
    if (buffer_) cholmod_free(BufferValues(), sizeof(double), buffer_, half_[0].common.get());
    buffer_ = nullptr;
    spill_.reset();
    parked_[0] = parked_[1] = false;
    in_place_ = false;
    c_second_.clear();
    whole_.reset();
    for (Half& h : half_) {
      h.Release();
      h.unknowns.clear();
      h.scatter.clear();
      h.from.clear();
      h.to.clear();
    }
    top_.clear();
    c_entries_.clear();
    values_.clear();
    entries_ = 0;
  }

  // One CHOLMOD factorisation of the whole, in the given order if any.
  void Whole(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
             const std::vector<int>& block_sizes, const std::vector<int>& order = {}) {
    whole_ = SparseCholesky::Create(Factorization::kSupernodalOrSimplicial);
    whole_->SetBlockOrdering(order.empty() ? given_ : order);
    whole_->Analyze(n, col_ptr, rows, block_sizes);
  }

  const double min_work_;
  const int nd_min_blocks_;
  const int threads_;
  const double resident_bytes_;  // negative: OverBudget's rule
  std::unique_ptr<SpillFile> spill_;  // out of core, when the factors outgrow the graph
  bool parked_[2] = {false, false};   // the current factor of each half is on disk
  double* buffer_ = nullptr;          // out of core: the one numeric factor in memory
  std::unique_ptr<ThreadPool> pool_;  // made at the first split
  std::unique_ptr<SparseCholesky> whole_;  // when not split
  std::vector<int> given_, used_;
  Half half_[2];
  std::vector<int> top_;          // the separator's unknowns, in order
  std::vector<Entry> c_entries_;  // entries of H in C: index (in place: in the first half), place in T
  std::vector<int> c_second_;  // in place: where each of c_entries_ lies in the second half
  bool in_place_ = false;
  std::vector<double> values_;    // H's values, as the caller writes them
  size_t entries_ = 0;            // H's entries
  Eigen::MatrixXd s_;                   // S, lower triangle
  Eigen::LLT<Eigen::MatrixXd, Eigen::Lower> schur_;
  Eigen::VectorXd through_[2], x_top_;  // solve workspace
};

}  // namespace

std::unique_ptr<SparseCholesky> CreateDomainCholesky(double min_work, int threads,
                                                     int nested_dissection_min_blocks,
                                                     double resident_factor_bytes) {
  return std::make_unique<DomainCholmod>(
      min_work, std::max(1, std::min(threads, 2)),
      nested_dissection_min_blocks < 0 ? kNestedDissectionMinBlocks : nested_dissection_min_blocks,
      resident_factor_bytes);
}

}  // namespace cairn
