// Scene-file errors in the tests: load a scene written to a temporary folder and look at the
// issues it reports (shared by the rigid-body and kinematic tests).
#pragma once

#include "core/errors.h"
#include "io/scene_loader.h"
#include "tests/temp_dir.h"

#include <string>
#include <vector>

namespace sph::testing {

/// The issues of `yaml` saved as scene.yaml in `dir` (empty when it loads).
inline std::vector<InputIssue> issuesOf(const TempDir& dir, const std::string& yaml) {
  const auto scene = dir.write("scene.yaml", yaml);
  try {
    io::loadScene(scene.string());
  } catch (const InputError& e) {
    return e.issues();
  }
  return {};
}

/// Whether some issue is on `line` and its message contains every one of `parts`.
inline bool hasIssue(const std::vector<InputIssue>& issues, int line, const std::vector<std::string>& parts) {
  for (const auto& i : issues) {
    if (i.line != line) continue;
    bool all = true;
    for (const auto& p : parts) all = all && i.message.find(p) != std::string::npos;
    if (all) return true;
  }
  return false;
}

/// The issues one per line, for test messages.
inline std::string dump(const std::vector<InputIssue>& issues) {
  std::string s;
  for (const auto& i : issues) s += i.str() + "\n";
  return s;
}

}  // namespace sph::testing
