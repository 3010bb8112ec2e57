// The sparse Cholesky factorisation on two threads: the pose graph is cut
// at a small separator into two halves, which two CHOLMOD instances
// factorise at once; the separator is finished as a dense matrix. Exact,
// with the same fill as one CHOLMOD factorisation in the same order.
#pragma once

#include <memory>

#include "cairn/linear/sparse_cholesky.h"

namespace cairn {

// The estimated work (multiply-adds) under which one thread is kept: below
// it, waking a second thread costs more than it saves.
constexpr double kMinWorkToSplit = 2e7;

// Splits when the estimated work is at least `min_work` and two threads
// would finish in at most 3/4 of one's time; otherwise it is CHOLMOD's own
// choice (Factorization::kSupernodalOrSimplicial) on one thread, in the same order.
// Whether and where it splits depends on the matrix alone, never on
// `threads`: with one thread the halves are factorised one after the other,
// with the same arithmetic, so the result is the same to the last bit.
// Graphs of `nested_dissection_min_blocks` blocks or more have their
// halves ordered by nested dissection too (-1: kNestedDissectionMinBlocks,
// block_ordering.h).
//
// Out of core: when the halves' two numeric factors would take more than
// `resident_factor_bytes` (negative: the larger of kResidentFloorBytes and
// kResidentBytesPerPair for each pair of blocks H joins), they are
// factorised one after the other and only one is held in memory at a time,
// the other in an unnamed temporary file (spill_file.h). Same arithmetic,
// the same result to the last bit; slower (one core, and the file's reads).
std::unique_ptr<SparseCholesky> CreateDomainCholesky(double min_work = kMinWorkToSplit,
                                                     int threads = 2,
                                                     int nested_dissection_min_blocks = -1,
                                                     double resident_factor_bytes = -1);

// A pose graph's solve holds, besides the factor, about 1.5 KB an edge (H,
// the graph, the vectors, the Jacobians): so the factor may hold as much
// again and the whole stays within 3 KB an edge (docs/robustness.md, "One
// half's factor on disk"). Below the floor the process's fixed memory is of
// the same order, and parking would cost time for little.
constexpr double kResidentBytesPerPair = 1536;
constexpr double kResidentFloorBytes = 256.0 * 1024 * 1024;

}  // namespace cairn
