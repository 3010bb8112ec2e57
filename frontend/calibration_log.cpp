#include "frontend/calibration_log.h"

#include <zlib.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "backend/graph_io.h"

namespace cairn {
namespace {

double Number(const std::vector<std::string>& tokens, size_t i, const std::string& file,
              size_t line) {
  if (i >= tokens.size())
    throw ParseError(file, line, tokens[0] + " line too short: no field " + std::to_string(i));
  char* end = nullptr;
  const double v = std::strtod(tokens[i].c_str(), &end);
  if (end == tokens[i].c_str() || *end != '\0' || !std::isfinite(v))
    throw ParseError(file, line, "not a finite number: '" + tokens[i] + "'");
  return v;
}

}  // namespace

CalibrationData ReadCarmenCalibration(const std::string& path) {
  // gzopen reads plain files as they are, so one path serves both.
  std::unique_ptr<gzFile_s, int (*)(gzFile)> gz(gzopen(path.c_str(), "rb"), gzclose);
  if (!gz) throw std::runtime_error("cannot open '" + path + "'");
  CalibrationData data;
  std::vector<char> buf(1 << 16);
  std::string line;
  size_t line_no = 0;
  bool have_odometry = false;  // an ODOM since the last scan
  SE2 last_odometry;
  for (;;) {
    // A FLASER line can exceed any fixed buffer: gather until the newline.
    line.clear();
    bool got = false;
    while (gzgets(gz.get(), buf.data(), static_cast<int>(buf.size()))) {
      got = true;
      line += buf.data();
      if (!line.empty() && line.back() == '\n') break;
    }
    if (!got) break;
    ++line_no;
    std::istringstream ss(line);
    std::vector<std::string> tokens;
    for (std::string t; ss >> t;) tokens.push_back(t);
    if (tokens.empty()) continue;
    if (tokens[0] == "ODOM") {
      last_odometry = SE2(Number(tokens, 1, path, line_no), Number(tokens, 2, path, line_no),
                          Number(tokens, 3, path, line_no));
      have_odometry = true;
    } else if (tokens[0] == "FLASER") {
      const double n = Number(tokens, 1, path, line_no);
      if (n < 0 || n != std::floor(n) || n > 100000)
        throw ParseError(path, line_no, "bad beam count '" + tokens[1] + "'");
      const size_t at = 2 + static_cast<size_t>(n);
      const SE2 pose(Number(tokens, at, path, line_no), Number(tokens, at + 1, path, line_no),
                     Number(tokens, at + 2, path, line_no));
      if (!data.reference_poses.empty()) {
        const SE2& previous = data.reference_poses.back();
        data.raw_increments.push_back(
            have_odometry ? previous.Between(last_odometry).ToVector() : Eigen::Vector3d::Zero());
        data.step_has_odometry.push_back(have_odometry);
      }
      data.reference_poses.push_back(pose);
      have_odometry = false;
    }
  }
  if (gzeof(gz.get()) == 0) {
    int err = 0;
    const char* msg = gzerror(gz.get(), &err);
    if (err != Z_OK && err != Z_STREAM_END)
      throw std::runtime_error(path + ": read error: " + (msg ? msg : "?"));
  }
  PairsFromTrajectory(&data);
  return data;
}

}  // namespace cairn
