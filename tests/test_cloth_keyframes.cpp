// Keyframed cloth anchors (issue 11, core/cloth.h AnchorTrack): anchored nodes follow a
// piecewise-linear path of offsets, held before the first key and after the last. Against the
// closed form (linear interpolation between keys) at frame ends, against the static cloth
// bitwise when the keys do not move, and bad input at its location. No fluid: about a second.
#include "core/cl_context.h"
#include "core/cloth.h"
#include "core/errors.h"
#include "core/model.h"
#include "core/simulation.h"
#include "io/scene_loader.h"
#include "tests/cloth_scenes.h"
#include "tests/run_binary.h"
#include "tests/scene_issues.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

using namespace sph;

namespace {

using sph::testing::clothScene;

/// A 6 x 4 sheet in the plane z = 0.5, centred at (0.5, 0.5).
ClothSpec sheet(ClothSolver solver) {
  ClothSpec c;
  c.name = "sheet";
  c.resolution_x = 6;
  c.resolution_y = 4;
  c.width = 0.1;
  c.length = 0.06;
  c.position = Eigen::Vector3d(0.5, 0.5, 0.5);
  c.solver = solver;
  return c;
}

AnchorKeyframeSpec key(double t, const Eigen::Vector3d& o) {
  AnchorKeyframeSpec k;
  k.time = t;
  k.offset = o;
  return k;
}

/// The closed form, written out here: the offset at t, linear between keys, held outside them.
Eigen::Vector3d expected(const std::vector<AnchorKeyframeSpec>& keys, double t) {
  if (t <= keys.front().time) return keys.front().offset;
  for (std::size_t k = 0; k + 1 < keys.size(); ++k)
    if (t < keys[k + 1].time)
      return keys[k].offset + (t - keys[k].time) / (keys[k + 1].time - keys[k].time) * (keys[k + 1].offset - keys[k].offset);
  return keys.back().offset;
}

std::vector<Eigen::Vector4f> positions(Simulation& sim) {
  std::vector<Eigen::Vector4f> x, v;
  sim.cloth()->read(x, v);
  return x;
}

}  // namespace

TEST_CASE("Cloth keyframes: anchored nodes follow the piecewise-linear path at every frame end", "[cloth][keyframes]") {
  // The x_min edge is keyframed: still until 0.05 s, then 0.04 m along x by 0.15 s, then 0.03 m
  // down by 0.2 s, then held. Frames at 60 Hz end between keys (mid-segment interpolation) and
  // past the last key (held). The nodes are set absolutely (placed + offset, in float), so the
  // tolerance is float rounding of a coordinate near 0.5 m: a few ulp, 1e-6 m.
  const std::vector<AnchorKeyframeSpec> keys = {key(0.05, {0, 0, 0}), key(0.15, {0.04, 0, 0}), key(0.2, {0.04, 0, -0.03})};
  for (ClothSolver solver : {ClothSolver::Xpbd, ClothSolver::Explicit}) {
    ClothSpec c = sheet(solver);
    ClothAnchorSpec edge;
    edge.type = AnchorType::Edge;
    edge.edge = ClothEdge::XMin;
    edge.keyframes = keys;
    c.anchors.push_back(edge);
    ClContext cl;
    const Compiled comp = compile(clothScene(c, 60, 2, 0.25));
    Simulation sim(comp.model, comp.initial, cl);
    const std::vector<Eigen::Vector3d> placed = cloth::nodePositions(c);
    double worst = 0, moved = 0;
    for (int f = 0; f < comp.model.num_frames; ++f) {
      sim.advanceFrame();
      const Eigen::Vector3d off = expected(keys, sim.time());
      const std::vector<Eigen::Vector4f> x = positions(sim);
      for (int j = 0; j < c.resolution_y; ++j) {
        const std::size_t k = static_cast<std::size_t>(j * c.resolution_x);  // node (0, j)
        worst = std::max(worst, (x[k].head<3>().cast<double>() - (placed[k] + off)).cwiseAbs().maxCoeff());
      }
      moved = std::max(moved, off.norm());
    }
    INFO((solver == ClothSolver::Xpbd ? "xpbd" : "explicit") << ": worst deviation " << worst << " m");
    CHECK(moved == Approx(0.05));  // the path was walked to its end (0.04, 0, -0.03)
    CHECK(worst < 1e-6);
  }
}

TEST_CASE("Cloth keyframes: anchors whose keys stay still equal the static cloth bitwise", "[cloth][keyframes]") {
  // The same sheet hung by its corners, once fixed (velocity 0) and once by keyframes of zero
  // offset: every node, bitwise, after 0.2 s, for both solvers.
  for (ClothSolver solver : {ClothSolver::Xpbd, ClothSolver::Explicit}) {
    ClothSpec fixed = sheet(solver);
    fixed.anchors.resize(1);  // corners
    ClothSpec keyed = fixed;
    keyed.anchors[0].keyframes = {key(0.0, {0, 0, 0}), key(0.1, {0, 0, 0})};
    ClContext cl;
    std::vector<std::vector<Eigen::Vector4f>> runs;
    for (const ClothSpec& c : {fixed, keyed}) {
      const Compiled comp = compile(clothScene(c, 60, 2, 0.2));
      Simulation sim(comp.model, comp.initial, cl);
      for (int f = 0; f < comp.model.num_frames; ++f) sim.advanceFrame();
      runs.push_back(positions(sim));
    }
    REQUIRE(runs[0].size() == runs[1].size());
    CHECK(std::memcmp(runs[0].data(), runs[1].data(), runs[0].size() * 16) == 0);
    // It moved: the comparison is not between two still sheets.
    float lowest = 1.0f;
    for (const Eigen::Vector4f& x : runs[0]) lowest = std::min(lowest, x.z());
    CHECK(lowest < 0.4999f);  // measured 0.4993 m (xpbd)
  }
}

TEST_CASE("Cloth keyframes: bad keyframes are reported at their location, exit 2", "[cloth][keyframes][input]") {
  using namespace sph::testing;
  TempDir dir;
  const std::string head =
      "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n"
      "fluid: {particle_spacing: 0.05}\n"
      "cloth:\n"
      "  - name: sheet\n"
      "    anchors:\n"
      "      - type: corners\n";
  // Loads when well formed.
  CHECK(issuesOf(dir, head + "        keyframes: [{time: 0, offset: [0, 0, 0]}, {time: 1, offset: [0, 0, 0.1]}]\n").empty());
  // Velocity and keyframes: at the velocity key.
  auto issues = issuesOf(dir, head +
                                  "        velocity: [0, 0, 1]\n"
                                  "        keyframes: [{time: 0, offset: [0, 0, 0]}]\n");
  INFO(dump(issues));
  CHECK(hasIssue(issues, 7, {"velocity", "keyframes", "not both"}));
  // Times not increasing: at the later key's time.
  issues = issuesOf(dir, head +
                             "        keyframes:\n"
                             "          - {time: 0.5, offset: [0, 0, 0]}\n"
                             "          - {time: 0.5, offset: [0, 0, 0.1]}\n");
  INFO(dump(issues));
  CHECK(hasIssue(issues, 9, {"keyframes[1].time", "strictly increase"}));
  // An empty list, a key without its offset, a negative time: at their keys.
  issues = issuesOf(dir, head + "        keyframes: []\n");
  CHECK(hasIssue(issues, 7, {"at least 1 key"}));
  issues = issuesOf(dir, head + "        keyframes: [{time: 0}]\n");
  CHECK(hasIssue(issues, 7, {"offset"}));
  issues = issuesOf(dir, head + "        keyframes: [{time: -1, offset: [0, 0, 0]}]\n");
  CHECK(hasIssue(issues, 7, {"time"}));
  // The command line: exit code 2 with file:line:col.
  const auto scene = dir.write("keys.yaml", head +
                                                "        keyframes:\n"
                                                "          - {time: 1, offset: [0, 0, 0]}\n"
                                                "          - {time: 0.5, offset: [0, 0, 0.1]}\n");
  const Result r = sphaptics(dir.path, {"validate", scene.string()});
  CHECK(r.code == 2);
  CHECK(r.err.find("keys.yaml:9:") != std::string::npos);
}
