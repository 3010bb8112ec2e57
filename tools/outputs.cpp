#include "tools/outputs.h"

#include <sys/stat.h>

#include <cctype>
#include <stdexcept>

namespace cairn::tools {
namespace {

bool EndsWithNoCase(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  for (size_t k = 0; k < suffix.size(); ++k)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + k])) !=
        std::tolower(static_cast<unsigned char>(suffix[k])))
      return false;
  return true;
}

// Written in place by OutputSet, whatever it is called.
bool IsStream(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
}

}  // namespace

void CommandOutputs::Input(const std::string& path) {
  if (!path.empty()) AddInput(path);
}

void CommandOutputs::Output(const std::string& path, const char* extension) {
  if (path.empty()) return;
  AddOutput(path);
  if (extension) extensions_.emplace_back(path, extension);
}

void CommandOutputs::GraphOutput(const std::string& path) {
  if (path.empty()) return;
  AddOutput(path);
  graphs_.push_back(path);
}

namespace {

GraphFormat FormatFor(const std::string& path) {
  return GraphFormatOf(path).value_or(GraphFormat::kG2o);
}

}  // namespace

void CommandOutputs::CheckGraphFits(const PoseGraph& graph) const {
  for (const std::string& path : graphs_) {
    if (FormatFor(path) != GraphFormat::kToro) continue;
    const std::string refusal = ToroRefusal(graph);
    if (!refusal.empty()) throw std::runtime_error(path + ": " + refusal);
  }
}

void CommandOutputs::WriteGraph(const std::string& path, const PoseGraph& graph) {
  const GraphFormat format = FormatFor(path);
  Write(path, [&](std::ostream& os) { cairn::WriteGraph(graph, format, os); });
}

void CommandOutputs::Check() {
  // Collisions first: an output that would overwrite an input is the worse news.
  OutputSet::Check();
  for (const auto& [path, extension] : extensions_)
    if (!EndsWithNoCase(path, extension) && !IsStream(path))
      throw std::runtime_error(path + ": an output extension cairn does not know here (it writes " +
                               extension.substr(1) + " there: name it *" + extension + ")");
  for (const std::string& path : graphs_)
    if (!GraphFormatOf(path) && !IsStream(path))
      throw std::runtime_error(path +
                               ": an output extension cairn does not know here (it writes a graph as "
                               "g2o, *.g2o, or as TORO, *.graph)");
}

}  // namespace cairn::tools
