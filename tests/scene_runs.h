// Paths of the test scenes and data, and the quiet, output-free run of a test scene (shared by the
// physics tests of both solvers).
#pragma once

#include "cli/runner.h"

#include <string>
#include <utility>
#include <vector>

namespace sph::testing {

inline std::string scenePath(const std::string& name) { return std::string(SPHAPTICS_SOURCE_DIR) + "/scenes/tests/" + name; }
inline std::string dataPath(const std::string& name) { return std::string(SPHAPTICS_SOURCE_DIR) + "/tests/data/" + name; }

/// A run of scenes/tests/<scene> that prints nothing and writes nothing, with --set overrides.
inline app::RunOptions quietRun(const std::string& scene, std::vector<std::string> sets = {}) {
  app::RunOptions o;
  o.scene = scenePath(scene);
  o.quiet = true;
  o.write_output = false;
  o.sets = std::move(sets);
  return o;
}

}  // namespace sph::testing
