// What the DFSPH speed work (issue 14) may not change: kernel timing (`run --profile-kernels`)
// leaves every result bitwise as it was, the Verlet-list skin is DFSPH's H/40 only (WCSPH keeps
// H/4, so its runs stay bitwise those of before), and the narrow neighbour lists (16-bit offsets)
// give bitwise the results of 32-bit ones. Small scenes from scenes/tests/.
#include "cli/runner.h"
#include "core/cl_context.h"
#include "core/model.h"
#include "core/simulation.h"
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

namespace {
struct ListsRun {
  uint64_t hash = 0;
  bool wide = false;
};
/// Steps `c` for `frames` frames; with `wide` the fluid lists are 32-bit indices from the first
/// step on (Simulation::useWideLists), else narrow where they fit (the default).
ListsRun runLists(const Compiled& c, int frames, bool wide) {
  ClContext cl;
  Simulation sim(c.model, c.initial, cl);
  if (wide) sim.useWideLists();
  for (int f = 0; f < frames; ++f) sim.advanceFrame();
  return {sim.stateHash(), sim.wideLists()};
}
}  // namespace

TEST_CASE("Narrow neighbour lists (16-bit offsets j - i) give bitwise the results of 32-bit lists", "[dfsph][profile]") {
  // The slab dam break (6,400 particles: every offset fits), 3 frames (30 ms): the same neighbours
  // in the same order, so the same state to the bit, with each solver and DFSPH's walls.
  for (const std::vector<std::string>& sets :
       {std::vector<std::string>{"fluid.solver=wcsph"}, {"fluid.solver=dfsph", "fluid.dfsph.walls=extrapolated"},
        {"fluid.solver=dfsph", "fluid.dfsph.walls=mirrored"}}) {
    INFO(sets.back());
    std::vector<std::string> all = sets;
    all.push_back("simulation.duration=0.03");
    const Compiled c = compile(io::loadScene(scenePath("dam_break_slab.yaml"), all));
    const ListsRun narrow = runLists(c, c.model.num_frames, false);
    const ListsRun wide = runLists(c, c.model.num_frames, true);
    CHECK_FALSE(narrow.wide);
    CHECK(wide.wide);
    CHECK(narrow.hash == wide.hash);
  }
}

TEST_CASE("Neighbour lists turn wide by themselves where an offset does not fit in 16 bits", "[dfsph][profile]") {
  // A slab of 128 x 128 x 6 = 98,304 particles (dx = 1 cm) in a closed box: cells of H + H/40 =
  // 2.05 cm hold two particle layers, ~32,800 particles per cell layer, so a particle's candidates
  // (the rows from (z-1, y-1) to (z+1, y+1) around its cell) lie more than 32,767 places from it
  // in cell order. The first list build finds it and the lists go wide, before any step uses them:
  // the state equals that of lists wide from the start, to the bit.
  const std::string yaml = R"(
simulation: {duration: 0.002, frame_rate: 1000, substeps: 1, gravity: [0, 0, -9.81]}
domain:
  min: [0.0, 0.0, 0.0]
  max: [1.3, 1.3, 0.1]
  closed: {x_min: true, x_max: true, y_min: true, y_max: true, z_min: true, z_max: true}
fluid:
  particle_spacing: 0.01
  solver: dfsph
  phases: [{name: water, rest_density: 1000}]
  blocks: [{phase: water, min: [0.005, 0.005, 0.0], max: [1.285, 1.285, 0.06]}]
output: {particles: false}
)";
  const Compiled c = compile(io::loadSceneFromString(yaml, "wide_lists.yaml"));
  REQUIRE(c.initial.size() > 32768);
  const ListsRun self = runLists(c, c.model.num_frames, false);
  const ListsRun wide = runLists(c, c.model.num_frames, true);
  CHECK(self.wide);
  CHECK(self.hash == wide.hash);
}
