// Probes (issue 12, item 8): the host-side reduction of the probe sums, the scene section's bad
// input, the stage mask, the sampling rate and probes.csv. Their physics (hydrostatic pressure at
// probes within 2 %, gauges within dx, the dam-break column height against Martin & Moyce) is
// checked in tests/test_physics.cpp on the runs that test already makes.
#include "cli/runner.h"
#include "core/errors.h"
#include "core/model.h"
#include "core/probes.h"
#include "io/scene_loader.h"
#include "tests/scene_issues.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace sph;

namespace {

/// The eight sums of one sample point (kernels/probes.cl): S, S_p, S_rho, S_v, F, B.
std::vector<float> sums(float S, float p, float rho, float F, float B) {
  return {S, S * p, S * rho, S * 0.5f, 0.0f, -S, F, B};
}

const char* kTank = R"(simulation:
  duration: 0.05
  frame_rate: 100
  substeps: 2
domain:
  min: [0, 0, 0]
  max: [0.1, 0.05, 0.1]
fluid:
  particle_spacing: 0.01
  blocks:
    - {min: [0, 0, 0], max: [0.1, 0.05, 0.05]}
)";

}  // namespace

TEST_CASE("probes: Shepard normalisation, dry points and the gauge's crossing", "[probes]") {
  // A wet point: values are the normalised sums.
  const auto wet = sums(0.9f, 1500.0f, 1002.0f, 0.95f, 0.0f);
  const ProbeSample::Point p = probeValue(wet.data());
  CHECK(p.pressure == Approx(1500.0).epsilon(1e-6));
  CHECK(p.density == Approx(1002.0).epsilon(1e-6));
  CHECK(p.velocity.x() == Approx(0.5).epsilon(1e-6));
  CHECK(p.velocity.z() == Approx(-1.0).epsilon(1e-6));
  // Against a wall half the kernel is wall: F = 0.5 of fluid is a full kernel's worth of fluid.
  CHECK(probeFill(sums(0.5f, 1.0f, 1.0f, 0.5f, 0.5f).data()) == Approx(1.0));
  CHECK(std::isfinite(probeValue(sums(0.5f, 1.0f, 1.0f, 0.5f, 0.5f).data()).pressure));
  // Less than half full (above the free surface): dry, NaN.
  CHECK(std::isnan(probeValue(sums(0.3f, 1.0f, 1.0f, 0.3f, 0.0f).data()).pressure));
  CHECK(std::isnan(probeValue(sums(0.0f, 0.0f, 0.0f, 0.0f, 0.0f).data()).density));

  // A gauge: fill 1, 1, 0.8, 0.4, 0.1 at dz = 1 mm: the crossing of 1/2 lies 3/4 of the way from
  // the third sample (0.8) to the fourth (0.4): 2.75 mm above the foot.
  std::vector<float> line;
  for (float f : {1.0f, 1.0f, 0.8f, 0.4f, 0.1f}) {
    const auto s = sums(f, 0.0f, 1000.0f, f, 0.0f);
    line.insert(line.end(), s.begin(), s.end());
  }
  CHECK(gaugeHeight(line.data(), 5, 1e-3) == Approx(2.75e-3).epsilon(1e-6));
  // Wet to the top: the line's length; dry at the foot: 0.
  CHECK(gaugeHeight(line.data(), 2, 1e-3) == Approx(1e-3));
  CHECK(gaugeHeight(line.data() + 8 * 4, 1, 1e-3) == 0.0);
}

TEST_CASE("probes: bad probe input is reported at its location", "[probes]") {
  testing::TempDir dir;
  const std::string base = kTank;
  // Duplicate and unsafe names (loader).
  auto issues = testing::issuesOf(dir, base + R"(probes:
  points:
    - {name: a, position: [0.05, 0.02, 0.02]}
    - {name: a, position: [0.05, 0.02, 0.03]}
  gauges:
    - {name: "x/../y", position: [0.05, 0.02, 0.0]}
)");
  INFO(testing::dump(issues));
  CHECK(testing::hasIssue(issues, 15, {"duplicate probe name 'a'"}));
  CHECK(testing::hasIssue(issues, 17, {"x/../y", "letters, digits"}));
  // A missing position (schema) and a point outside the domain (compile).
  issues = testing::issuesOf(dir, base + "probes:\n  points:\n    - {name: a}\n");
  CHECK(testing::hasIssue(issues, 14, {"position"}));
  const auto scene = dir.write("outside.yaml", base + "probes:\n  gauges:\n    - {name: g, position: [0.5, 0.02, 0.0]}\n");
  bool thrown = false;
  try {
    compile(io::loadScene(scene.string()));
  } catch (const InputError& e) {
    thrown = true;
    REQUIRE(!e.issues().empty());
    CHECK(e.issues()[0].line == 14);
    CHECK(e.issues()[0].message.find("outside the domain") != std::string::npos);
  }
  CHECK(thrown);
}

TEST_CASE("probes: no section, no probe kernel. With one, probes.csv at the set rate", "[probes]") {
  testing::TempDir dir;
  // Without the section: the stage is off and no probe kernel is enqueued.
  app::RunOptions o;
  o.scene = dir.write("plain.yaml", kTank).string();
  o.quiet = true;
  o.write_output = false;
  const app::RunResult plain = app::runScene(o);
  REQUIRE(plain.exit_code == 0);
  CHECK(plain.dispatch_counts.count("probe_sample") == 0);

  // With it, sampled at 200 per simulated second over 0.05 s with a step of 5 ms: 10 samples (at the
  // first step at or after each multiple of 5 ms), each a row of probes.csv.
  o.scene = dir.write("probed.yaml", std::string(kTank) + R"(probes:
  rate: 200
  points:
    - {name: low, position: [0.05, 0.025, 0.015]}
    - {name: above, position: [0.05, 0.025, 0.09]}
  gauges:
    - {name: column, position: [0.05, 0.025, 0.0]}
)").string();
  o.write_output = true;
  o.out = (dir.path / "out").string();
  const app::RunResult r = app::runScene(o);
  REQUIRE(r.exit_code == 0);
  CHECK(r.dispatch_counts.at("probe_sample") == 10);
  std::ifstream in(dir.path / "out" / "probes.csv");
  REQUIRE(in);
  std::string line, header;
  std::vector<std::string> rows;
  while (std::getline(in, line)) {
    if (line.rfind("#", 0) == 0) continue;
    if (header.empty()) header = line;
    else rows.push_back(line);
  }
  CHECK(header ==
        "time,low_pressure,low_density,low_vx,low_vy,low_vz,above_pressure,above_density,above_vx,above_vy,above_vz,"
        "column_height");
  REQUIRE(rows.size() == 10);
  // The first row: t = 0, a probe in the water (pressure finite), one above it (nan), and the
  // column's height within a spacing of the 5 cm of water.
  std::vector<std::string> cells;
  std::stringstream ss(rows[0]);
  for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
  REQUIRE(cells.size() == 12);
  CHECK(std::stod(cells[0]) == 0.0);
  CHECK(std::isfinite(std::stod(cells[1])));
  CHECK(cells[6] == "nan");
  CHECK(std::abs(std::stod(cells[11]) - 0.05) < 0.01);
}
