// What the DFSPH speed work (issue 14) may not change: kernel timing (`run --profile-kernels`)
// leaves every result bitwise as it was, and the Verlet-list skin is DFSPH's H/40 only (WCSPH keeps
// H/4, so its runs stay bitwise those of before). Small scenes from scenes/tests/.
#include "cli/runner.h"
#include "core/model.h"
#include "io/scene_loader.h"
#include "tests/scene_runs.h"

#include <catch2/catch.hpp>

using namespace sph;
using testing::quietRun;
using testing::scenePath;

TEST_CASE("Kernel profiling times every kernel and changes no result (DFSPH, extrapolated walls)", "[dfsph][profile]") {
  app::RunOptions o = quietRun("dam_break_slab.yaml", {"fluid.solver=dfsph", "fluid.dfsph.walls=extrapolated"});
  o.duration = 0.04;
  const app::RunResult plain = app::runScene(o);
  o.profile_kernels = true;
  const app::RunResult timed = app::runScene(o);
  REQUIRE(plain.exit_code == 0);
  REQUIRE(timed.exit_code == 0);
  // the same state, the same solver iterations and the same dispatches
  CHECK(timed.state_hash == plain.state_hash);
  CHECK(timed.profile.density_iterations == plain.profile.density_iterations);
  CHECK(timed.dispatch_counts == plain.dispatch_counts);
  // every dispatched kernel has a time (wall and process CPU); none without the flag
  CHECK(plain.kernel_seconds.empty());
  for (const auto& [name, count] : timed.dispatch_counts) {
    INFO(name);
    REQUIRE(timed.kernel_seconds.count(name) == 1);
    CHECK(timed.kernel_seconds.at(name) > 0.0);
    CHECK(timed.kernel_cpu_seconds.count(name) == 1);
  }
  CHECK(timed.kernel_seconds.count("dfsph_jacobi") == 1);
}

TEST_CASE("Verlet-list skin: H/40 with solver dfsph, H/4 with wcsph", "[dfsph][profile]") {
  const Compiled w = compile(io::loadScene(scenePath("dam_break_slab.yaml"), {"fluid.solver=wcsph"}));
  const Compiled d = compile(io::loadScene(scenePath("dam_break_slab.yaml"), {"fluid.solver=dfsph"}));
  CHECK(w.model.skin == Approx(0.25 * w.model.support).epsilon(1e-12));
  CHECK(d.model.skin == Approx(0.025 * d.model.support).epsilon(1e-12));
  // the grid's cells are the list radius H + skin
  CHECK(w.model.params.cell_size == Approx(1.25 * w.model.support).epsilon(1e-6));
  CHECK(d.model.params.cell_size == Approx(1.025 * d.model.support).epsilon(1e-6));
}
