#include "cairn/solvers/linear_solver.h"

#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

namespace cairn {

double ParseFactorMemory(const std::string& text) {
  if (text == "auto") return -1;
  if (text == "unlimited") return std::numeric_limits<double>::infinity();
  char* end = nullptr;
  const double mb = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !(mb >= 0) || !std::isfinite(mb))
    throw std::invalid_argument("--gn-factor-memory: expected auto, unlimited or a number of MB >= 0, "
                                "got '" + text + "'");
  return mb * 1024 * 1024;
}

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
    case CholeskyKind::kConjugateGradients: return "cg-subgraph";
    case CholeskyKind::kConjugateGradientsJacobi: return "cg-block-jacobi";
  }
  return "?";
}

CholeskyKind ResolveCholeskyKind(CholeskyKind kind, int /*threads*/) {
  return kind == CholeskyKind::kAuto ? CholeskyKind::kTwoHalves : kind;
}

}  // namespace cairn
