#include "cairn/solvers/linear_solver.h"

#include <stdexcept>

namespace cairn {

CholeskyKind ParseCholeskyKind(const std::string& name) {
  if (name == "auto") return CholeskyKind::kAuto;
  if (name == "cholmod" || name == "supernodal") return CholeskyKind::kSupernodal;
  if (name == "simplicial") return CholeskyKind::kSimplicial;
  if (name == "cholmod-auto") return CholeskyKind::kSupernodalOrSimplicial;
  if (name == "parallel") return CholeskyKind::kTwoHalves;
  if (name == "eigen") return CholeskyKind::kEigenLDLT;
  throw std::invalid_argument("unknown linear solver '" + name +
                              "' (auto, supernodal, simplicial, cholmod-auto, parallel or eigen)");
}

const char* ToString(CholeskyKind kind) {
  switch (kind) {
    case CholeskyKind::kAuto: return "auto";
    case CholeskyKind::kSupernodal: return "cholmod-supernodal";
    case CholeskyKind::kSimplicial: return "cholmod-simplicial";
    case CholeskyKind::kSupernodalOrSimplicial: return "cholmod-auto";
    case CholeskyKind::kEigenLDLT: return "eigen-ldlt";
    case CholeskyKind::kTwoHalves: return "cholmod-parallel";
  }
  return "?";
}

CholeskyKind ResolveCholeskyKind(CholeskyKind kind, int threads) {
  if (kind != CholeskyKind::kAuto) return kind;
  return threads >= 2 ? CholeskyKind::kTwoHalves : CholeskyKind::kSupernodalOrSimplicial;
}

}  // namespace cairn
