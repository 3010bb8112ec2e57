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
  if (name == "qr") return CholeskyKind::kQR;
  if (name == "cg") return CholeskyKind::kConjugateGradients;
  if (name == "cg-jacobi") return CholeskyKind::kConjugateGradientsJacobi;
  throw std::invalid_argument("unknown linear solver '" + name +
                              "' (auto, supernodal, simplicial, cholmod-auto, parallel, eigen, qr, "
                              "cg or cg-jacobi)");
}

const char* ToString(CholeskyKind kind) {
  switch (kind) {
    case CholeskyKind::kAuto: return "auto";
    case CholeskyKind::kSupernodal: return "cholmod-supernodal";
    case CholeskyKind::kSimplicial: return "cholmod-simplicial";
    case CholeskyKind::kSupernodalOrSimplicial: return "cholmod-auto";
    case CholeskyKind::kEigenLDLT: return "eigen-ldlt";
    case CholeskyKind::kTwoHalves: return "cholmod-parallel";
    case CholeskyKind::kQR: return "spqr";
    case CholeskyKind::kConjugateGradients: return "cg-spanning-tree";
    case CholeskyKind::kConjugateGradientsJacobi: return "cg-block-jacobi";
  }
  return "?";
}

CholeskyKind ResolveCholeskyKind(CholeskyKind kind, int /*threads*/) {
  return kind == CholeskyKind::kAuto ? CholeskyKind::kTwoHalves : kind;
}

}  // namespace cairn
