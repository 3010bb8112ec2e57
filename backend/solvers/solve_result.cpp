#include "cairn/solvers/solve_result.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ostream>
#include <stdexcept>

namespace cairn {

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

namespace {

// JSON has no NaN or infinity; null keeps the file parseable.
std::string JsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

bool LooksNumeric(const std::string& s) {
  if (s.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  return *end == '\0' && std::isfinite(v) && s.find_first_of("xXnN") == std::string::npos;
}

}  // namespace

RobustLoss ParseRobustLoss(const std::string& text) {
  if (text.empty() || text == "none") return {};
  const size_t colon = text.find(':');
  const std::string name = text.substr(0, colon);
  RobustLoss loss;
  if (name == "huber") {
    loss.kind = RobustLoss::kHuber;
  } else if (name == "cauchy") {
    loss.kind = RobustLoss::kCauchy;
  } else if (name == "dcs") {
    loss.kind = RobustLoss::kDcs;
  } else {
    throw std::invalid_argument("unknown robust loss '" + text +
                                "' (expected none, huber:DELTA, cauchy:DELTA or dcs:PHI)");
  }
  if (colon == std::string::npos)
    throw std::invalid_argument("robust loss '" + text + "' needs a width: " + name + ":DELTA");
  const std::string value = text.substr(colon + 1);
  char* end = nullptr;
  loss.delta = std::strtod(value.c_str(), &end);
  if (value.empty() || *end != '\0' || !std::isfinite(loss.delta) || loss.delta <= 0)
    throw std::invalid_argument("robust loss '" + text + "': DELTA must be a positive number");
  return loss;
}

std::string ToString(const RobustLoss& loss) {
  char buf[64];
  switch (loss.kind) {
    case RobustLoss::kNone: return "none";
    case RobustLoss::kHuber: std::snprintf(buf, sizeof buf, "huber:%g", loss.delta); break;
    case RobustLoss::kCauchy: std::snprintf(buf, sizeof buf, "cauchy:%g", loss.delta); break;
    case RobustLoss::kDcs: std::snprintf(buf, sizeof buf, "dcs:%g", loss.delta); break;
  }
  return buf;
}

void WriteReportJson(const SolveResult& r, std::ostream& out,
                     const std::vector<std::pair<std::string, std::string>>& context) {
  out << "{\n";
  for (const auto& [key, value] : context)
    out << "  " << JsonString(key) << ": " << (LooksNumeric(value) ? value : JsonString(value))
        << ",\n";
  out << "  \"solver\": " << JsonString(r.solver) << ",\n"
      << "  \"linear_solver\": " << JsonString(r.linear_solver) << ",\n"
      << "  \"initial_chi2\": " << JsonNumber(r.initial_chi2) << ",\n"
      << "  \"final_chi2\": " << JsonNumber(r.final_chi2) << ",\n"
      << "  \"iterations\": " << r.iterations << ",\n"
      << "  \"time_s\": " << JsonNumber(r.time_s) << ",\n"
      << "  \"setup_time_s\": " << JsonNumber(r.setup_time_s) << ",\n"
      << "  \"linearize_time_s\": " << JsonNumber(r.linearize_time_s) << ",\n"
      << "  \"linear_solver_time_s\": " << JsonNumber(r.linear_solver_time_s) << ",\n"
      << "  \"termination\": " << JsonString(r.termination) << ",\n"
      << "  \"message\": " << JsonString(r.message) << ",\n"
      << "  \"converged\": " << (r.converged ? "true" : "false") << ",\n"
      << "  \"usable\": " << (r.usable ? "true" : "false") << ",\n"
      << "  \"trace\": [";
  for (size_t i = 0; i < r.trace.size(); ++i) {
    const IterationRecord& t = r.trace[i];
    out << (i ? ",\n" : "\n") << "    {\"iteration\": " << t.iteration
        << ", \"chi2\": " << JsonNumber(t.chi2) << ", \"step_norm\": " << JsonNumber(t.step_norm)
        << ", \"time_s\": " << JsonNumber(t.time_s)
        << ", \"accepted\": " << (t.accepted ? "true" : "false")
        << ", \"linear_solver_time_s\": " << JsonNumber(t.linear_solver_time_s) << "}";
  }
  out << (r.trace.empty() ? "]\n" : "\n  ]\n") << "}\n";
}

bool IsUsableEstimate(double initial_objective, double final_objective) {
  return std::isfinite(final_objective) && final_objective <= initial_objective;
}

std::string FormatIteration(const IterationRecord& t) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "iter %3d  chi2 %.9e  |step| %.3e  %s  %8.3f s", t.iteration,
                t.chi2, t.step_norm, t.accepted ? "accepted" : "refused ", t.time_s);
  return buf;
}

}  // namespace cairn
