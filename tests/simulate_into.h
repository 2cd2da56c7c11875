// A quiet, in-process run of a scene into an output folder, for the tests that read what a run
// wrote (the viewer's screenshots, the Blender renders).
#pragma once

#include "cli/runner.h"

#include <catch2/catch.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace sph::testing {

/// Simulates `scene` for `duration` (unit: s) into `out` through the runner, with --set overrides.
inline void simulate(const std::filesystem::path& scene, const std::filesystem::path& out, double duration,
                     const std::vector<std::string>& sets) {
  app::RunOptions opt;
  opt.scene = scene.string();
  opt.out = out.string();
  opt.duration = duration;
  opt.sets = sets;
  opt.quiet = true;
  const app::RunResult r = app::runScene(opt);
  INFO(r.message);
  REQUIRE(r.exit_code == 0);
}

}  // namespace sph::testing
