// Scene loading and the schema table: values and defaults, every class of input error with its
// exact 1-based line:col, --set overrides, schemaText() and sceneToJson().
//
// The YAML texts below are written one line per string literal with the line number in a comment,
// so that the expected locations can be read off the source.
#include "core/errors.h"
#include "core/scene_spec.h"
#include "io/scene_loader.h"
#include "io/schema.h"
#include "io/schema_table.h"

#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using sph::InputError;
using sph::InputIssue;
using sph::SceneSpec;
using sph::io::loadScene;
using sph::io::loadSceneFromString;

namespace {

/// The issues of the InputError that loading `yaml` throws (fails the test when nothing is thrown).
std::vector<InputIssue> issuesOf(const std::string& yaml, const std::vector<std::string>& overrides = {}) {
  try {
    loadSceneFromString(yaml, "scene.yaml", overrides);
  } catch (const InputError& e) {
    return e.issues();
  }
  FAIL("expected an InputError for:\n" << yaml);
  return {};
}

/// Whether some issue is at file:line:col and its message contains every given fragment.
bool hasIssue(const std::vector<InputIssue>& issues, const std::string& file, int line, int col,
              const std::vector<std::string>& fragments) {
  for (const auto& issue : issues) {
    if (issue.file != file || issue.line != line || issue.col != col) continue;
    bool all = true;
    for (const auto& fragment : fragments) all = all && issue.message.find(fragment) != std::string::npos;
    if (all) return true;
  }
  return false;
}

std::string dump(const std::vector<InputIssue>& issues) {
  std::string s;
  for (const auto& issue : issues) s += issue.str() + "\n";
  return s;
}

/// REQUIRE with every issue printed when it fails.
#define REQUIRE_MESSAGE(cond, msg) \
  do {                             \
    INFO(msg);                     \
    REQUIRE(cond);                 \
  } while (0)
/// An issue at scene.yaml:line:col whose message contains every fragment.
#define REQUIRE_ISSUE(issues, line, col, ...) \
  REQUIRE_MESSAGE(hasIssue(issues, "scene.yaml", line, col, {__VA_ARGS__}), dump(issues))
/// An issue against "--set" (no line) whose message contains every fragment.
#define REQUIRE_SET_ISSUE(issues, ...) REQUIRE_MESSAGE(hasIssue(issues, "--set", 0, 0, {__VA_ARGS__}), dump(issues))

const std::string kDomain = "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n";

using sph::testing::TempDir;

}  // namespace

// ---------------------------------------------------------------------------------------------
// Valid scenes
// ---------------------------------------------------------------------------------------------

TEST_CASE("a valid scene loads with its values and the defaults", "[io]") {
  const std::string yaml =
      "simulation:\n"                          // 1
      "  duration: 1.5\n"                      // 2
      "  gravity: [0, 0, -9.0]\n"              // 3
      "  kernel: wendland_c2\n"                // 4
      "domain:\n"                              // 5
      "  min: [0, 0, 0]\n"                     // 6
      "  max: [1, 0.5, 0.8]\n"                 // 7
      "  closed: {z_max: true, x_min: no}\n"   // 8
      "fluid:\n"                               // 9
      "  particle_spacing: 0.01\n"             // 10
      "  phases:\n"                            // 11
      "    - name: water\n"                    // 12
      "    - name: honey\n"                    // 13
      "      rest_density: 1420\n"             // 14
      "      viscosity: 1e-2\n"                // 15
      "      colour: [0.9, 0.6, 0.1]\n"        // 16
      "  blocks:\n"                            // 17
      "    - min: [0, 0, 0]\n"                 // 18
      "      max: [0.3, 0.5, 0.4]\n"           // 19
      "    - phase: honey\n"                   // 20
      "      min: [0.5, 0, 0]\n"               // 21
      "      max: [0.7, 0.2, 0.2]\n"           // 22
      "      velocity: [0, 0, -1]\n"           // 23
      "  inflows:\n"                           // 24
      "    - name: tap\n"                      // 25
      "      position: [0.5, 0.25, 0.7]\n"     // 26
      "      stop: 0.5\n"                      // 27
      "output:\n"                              // 28
      "  directory: results\n";                // 29
  const SceneSpec s = loadSceneFromString(yaml, "scene.yaml");
  const SceneSpec d;  // defaults

  // simulation: given values, the rest defaulted
  CHECK(s.simulation.duration == 1.5);
  CHECK(s.simulation.gravity == Eigen::Vector3d(0, 0, -9.0));
  CHECK(s.simulation.kernel == sph::KernelType::WendlandC2);
  CHECK(s.simulation.frame_rate == d.simulation.frame_rate);
  CHECK(s.simulation.substeps == d.simulation.substeps);
  CHECK(s.simulation.cfl == d.simulation.cfl);
  CHECK(s.simulation.numerical_errors == sph::NumericalPolicy::Abort);

  // domain: closed walls merged with the defaults (all but z_max closed)
  CHECK(s.domain.max == Eigen::Vector3d(1, 0.5, 0.8));
  CHECK(s.domain.closed == std::array<bool, 6>{false, true, true, true, true, true});
  CHECK(s.domain.boundary_layers == d.domain.boundary_layers);

  // fluid
  CHECK(s.fluid.particle_spacing == 0.01);
  CHECK(s.fluid.equation_of_state == sph::EquationOfState::Linear);
  REQUIRE(s.fluid.phases.size() == 2);
  CHECK(s.fluid.phases[0].name == "water");
  CHECK(s.fluid.phases[0].rest_density == 1000.0);
  CHECK(s.fluid.phases[1].name == "honey");
  CHECK(s.fluid.phases[1].rest_density == 1420.0);
  CHECK(s.fluid.phases[1].viscosity == 1e-2);
  CHECK(s.fluid.phases[1].colour == Eigen::Vector3d(0.9, 0.6, 0.1));
  REQUIRE(s.fluid.blocks.size() == 2);
  CHECK(s.fluid.blocks[0].phase == "water");  // default: the first phase
  CHECK(s.fluid.blocks[1].phase == "honey");
  CHECK(s.fluid.blocks[1].velocity == Eigen::Vector3d(0, 0, -1));
  CHECK(s.fluid.blocks[0].velocity == Eigen::Vector3d::Zero());
  REQUIRE(s.fluid.inflows.size() == 1);
  const auto& tap = s.fluid.inflows[0];
  CHECK(tap.name == "tap");
  CHECK(tap.phase == "water");
  CHECK(tap.shape == sph::NozzleShape::Circle);
  CHECK(tap.direction == Eigen::Vector3d(0, 0, -1));
  CHECK(tap.start == 0.0);
  CHECK(tap.stop == 0.5);
  CHECK(tap.radius == sph::InflowSpec{}.radius);

  // Locations of sections and items (1-based), and paths
  CHECK(s.simulation.loc.file == "scene.yaml");
  CHECK(s.simulation.loc.line == 1);
  CHECK(s.simulation.loc.col == 1);
  CHECK(s.fluid.loc.line == 9);
  CHECK(s.fluid.phases[1].loc.line == 13);
  CHECK(s.fluid.phases[1].loc.col == 7);
  CHECK(s.fluid.blocks[1].loc.line == 20);
  CHECK(s.fluid.inflows[0].loc.line == 25);
  CHECK(s.output.loc.line == 28);
  const fs::path scene = fs::absolute("scene.yaml").lexically_normal();
  CHECK(s.source_file == scene.string());
  CHECK(s.output.directory == (scene.parent_path() / "results").string());
}

TEST_CASE("a minimal scene gets every default of core/scene_spec.h", "[io]") {
  const SceneSpec s = loadSceneFromString(kDomain, "minimal.yaml");
  const SceneSpec d;
  CHECK(s.simulation.duration == d.simulation.duration);
  CHECK(s.simulation.frame_rate == d.simulation.frame_rate);
  CHECK(s.simulation.substeps == d.simulation.substeps);
  CHECK(s.simulation.gravity == d.simulation.gravity);
  CHECK(s.simulation.gravity_ramp == d.simulation.gravity_ramp);
  CHECK(s.simulation.kernel == d.simulation.kernel);
  CHECK(s.simulation.support_ratio == d.simulation.support_ratio);
  CHECK(s.simulation.time_step_control == d.simulation.time_step_control);
  CHECK(s.simulation.cfl == d.simulation.cfl);
  CHECK(s.simulation.numerical_errors == d.simulation.numerical_errors);
  CHECK(s.domain.closed == d.domain.closed);
  CHECK(s.domain.boundary_layers == d.domain.boundary_layers);
  CHECK(s.fluid.particle_spacing == d.fluid.particle_spacing);
  CHECK(s.fluid.equation_of_state == d.fluid.equation_of_state);
  CHECK(s.fluid.speed_of_sound == d.fluid.speed_of_sound);
  CHECK(s.fluid.viscosity_model == d.fluid.viscosity_model);
  CHECK(s.fluid.artificial_viscosity == d.fluid.artificial_viscosity);
  CHECK(s.fluid.body_viscosity == d.fluid.body_viscosity);
  CHECK(s.fluid.body_ambient_pressure == d.fluid.body_ambient_pressure);
  CHECK(s.fluid.boundary_velocity == d.fluid.boundary_velocity);
  CHECK(s.fluid.colour_diffusion == d.fluid.colour_diffusion);
  CHECK(s.fluid.clamp_negative_pressure == d.fluid.clamp_negative_pressure);
  CHECK(s.fluid.background_pressure == d.fluid.background_pressure);
  CHECK(s.fluid.max_particles == d.fluid.max_particles);
  CHECK(s.fluid.blocks.empty());
  CHECK(s.fluid.inflows.empty());
  CHECK(s.output.directory.empty());  // not given: the CLI picks ./out/<scene stem>
  CHECK(s.output.particles == d.output.particles);

  // No phases given: one default phase "water" with the PhaseSpec defaults.
  REQUIRE(s.fluid.phases.size() == 1);
  CHECK(s.fluid.phases[0].name == "water");
  CHECK(s.fluid.phases[0].rest_density == sph::PhaseSpec{}.rest_density);
  CHECK(s.fluid.phases[0].viscosity == sph::PhaseSpec{}.viscosity);
  CHECK(s.fluid.phases[0].colour == sph::PhaseSpec{}.colour);
}

TEST_CASE("the schema defaults are read from core/scene_spec.h", "[io]") {
  // Every leaf key's default text equals the text of the default-constructed field.
  SceneSpec d;
  d.fluid.phases.resize(1);
  d.fluid.blocks.resize(1);
  d.fluid.inflows.resize(1);
  d.rigid_bodies.resize(1);
  d.cloth.resize(1);
  d.cloth[0].anchors.resize(1);
  d.soft_bodies.resize(1);
  d.soft_bodies[0].anchors.resize(1);
  d.probes.points.resize(1);
  d.probes.gauges.resize(1);
  d.haptics.path.resize(1);
  d.haptics.waypoints.resize(1);
  d.haptics.buttons.resize(1);
  for (const auto& key : sph::io::schemaTable()) {
    if (!key.isLeaf() || key.required || !key.default_note.empty()) continue;
    INFO(key.path);
    std::string expected = sph::io::valueText(key.get(d, 0));
    if (key.type == sph::io::KeyType::String) expected = "\"" + expected + "\"";
    CHECK(sph::io::defaultText(key) == expected);
  }
  CHECK(sph::io::defaultText(*sph::io::findKey("simulation.cfl")) == "0.4");
  CHECK(sph::io::defaultText(*sph::io::findKey("simulation.gravity")) == "[0, 0, -9.81]");
  CHECK(sph::io::defaultText(*sph::io::findKey("simulation.kernel")) == "cubic_spline");
  CHECK(sph::io::defaultText(*sph::io::findKey("fluid.inflows[].stop")) == "inf");
}

// ---------------------------------------------------------------------------------------------
// Errors, each with its location
// ---------------------------------------------------------------------------------------------

TEST_CASE("unknown keys are reported with a suggestion", "[io]") {
  const std::string yaml =
      kDomain +                       // 1
      "fluid:\n"                      // 2
      "  phases:\n"                   // 3
      "    - name: water\n"           // 4
      "      viscosty: 1e-3\n"        // 5
      "  blocs: []\n"                 // 6
      "outptu:\n"                     // 7
      "  foo: 1\n";                   // 8
  const auto issues = issuesOf(yaml);
  REQUIRE_ISSUE(issues, 5, 7, "unknown key 'viscosty'", "did you mean 'viscosity'?");
  REQUIRE_ISSUE(issues, 6, 3, "unknown key 'blocs'", "did you mean 'blocks'?");
  REQUIRE_ISSUE(issues, 7, 1, "unknown key 'outptu'", "did you mean 'output'?");
  CHECK(issues.size() == 3);  // nothing is reported inside an unknown section

  // A known name in the wrong place says where it belongs.
  const auto misplaced = issuesOf(kDomain + "fluid:\n  rest_density: 900\n");
  REQUIRE_ISSUE(misplaced, 3, 3, "unknown key 'rest_density'", "fluid.phases[].rest_density");
  // The message format is file:line:col: message.
  CHECK(misplaced[0].str() == "scene.yaml:3:3: " + misplaced[0].message);
}

TEST_CASE("values of the wrong type are reported where they are", "[io]") {
  const std::string yaml =
      "simulation:\n"              // 1
      "  duration: fast\n"         // 2   value at col 13
      "  gravity: 9.81\n"          // 3   col 12: scalar where vec3 expected
      "  substeps: 2.5\n"          // 4   col 13: float where int expected
      "domain:\n"                  // 5
      "  min: [0, 0]\n"            // 6   col 8: vec3 of length 2
      "  max: [1, one, 1]\n"       // 7   col 12: component not a number
      "fluid: [1, 2]\n"            // 8   col 8: list where a map is expected
      "output:\n"                  // 9
      "  particles: \"yes\"\n";    // 10  col 14: a quoted string is not a bool
  const auto issues = issuesOf(yaml);
  REQUIRE_ISSUE(issues, 2, 13, "'simulation.duration' must be a number (unit: s), got 'fast'");
  REQUIRE_ISSUE(issues, 3, 12, "'simulation.gravity' must be a list of 3 numbers", "got '9.81'");
  REQUIRE_ISSUE(issues, 4, 13, "'simulation.substeps' must be an integer", "got '2.5'");
  REQUIRE_ISSUE(issues, 6, 8, "'domain.min' must be a list of 3 numbers", "got a list of 2 item(s)");
  REQUIRE_ISSUE(issues, 7, 12, "'domain.max[1]' must be a finite number", "got 'one'");
  REQUIRE_ISSUE(issues, 8, 8, "'fluid' must be a map", "got a list of 2 item(s)");
  REQUIRE_ISSUE(issues, 10, 14, "'output.particles' must be true or false", "quoted string \"yes\"");
  // All errors of the file at once, sorted by line.
  REQUIRE(issues.size() == 7);
  for (std::size_t i = 1; i < issues.size(); ++i) CHECK(issues[i - 1].line <= issues[i].line);
}

TEST_CASE("out-of-range numbers and disallowed enum values list what is allowed", "[io]") {
  const std::string yaml =
      "simulation:\n"                     // 1
      "  cfl: 1.5\n"                      // 2   col 8
      "  substeps: 0\n"                   // 3   col 13
      "  kernel: cubic\n"                 // 4   col 11
      "  time_step_control: subdivid\n"   // 5   col 22
      "  duration: .inf\n"                // 6   col 13
      "domain:\n"                         // 7
      "  min: [0, 0, 0]\n"                // 8
      "  max: [1, 1, 1]\n"                // 9
      "  boundary_layers: 7\n"            // 10  col 20
      "fluid:\n"                          // 11
      "  particle_spacing: -0.01\n"       // 12  col 21
      "  phases:\n"                       // 13
      "    - name: a\n"                   // 14
      "      colour: [0.5, 1.5, 0]\n";    // 15  second component at col 21
  const auto issues = issuesOf(yaml);
  REQUIRE_ISSUE(issues, 2, 8, "'simulation.cfl' = 1.5 is out of range (must be in (0, 1])");
  REQUIRE_ISSUE(issues, 3, 13, "'simulation.substeps' = 0 is out of range (must be >= 1)");
  REQUIRE_ISSUE(issues, 4, 11, "'simulation.kernel' = 'cubic' is not allowed", "allowed values: cubic_spline, wendland_c2");
  REQUIRE_ISSUE(issues, 5, 22, "allowed values: subdivide, warn", "did you mean 'subdivide'?");
  REQUIRE_ISSUE(issues, 6, 13, "'simulation.duration' must be finite");
  REQUIRE_ISSUE(issues, 10, 20, "'domain.boundary_layers' = 7 is out of range (must be in [1, 4])");
  REQUIRE_ISSUE(issues, 12, 21, "'fluid.particle_spacing' = -0.01 is out of range (must be > 0, unit: m)");
  REQUIRE_ISSUE(issues, 15, 21, "'fluid.phases[0].colour[1]' = 1.5 is out of range (must be in [0, 1])");
  CHECK(issues.size() == 8);
}

TEST_CASE("missing required keys are reported at their section or item", "[io]") {
  const std::string yaml =
      "domain:\n"                    // 1   domain.max missing
      "  min: [0, 0, 0]\n"           // 2
      "fluid:\n"                     // 3
      "  phases:\n"                  // 4
      "    - rest_density: 900\n"    // 5   item at col 7 has no name
      "  inflows:\n"                 // 6
      "    - name: tap\n";           // 7   item at col 7 has no position
  const auto issues = issuesOf(yaml);
  REQUIRE_ISSUE(issues, 1, 1, "missing required key 'domain.max'");
  REQUIRE_ISSUE(issues, 5, 7, "missing required key 'fluid.phases[0].name'");
  REQUIRE_ISSUE(issues, 7, 7, "missing required key 'fluid.inflows[0].position'");
  CHECK(issues.size() == 3);

  // A scene without a domain section misses domain.min and domain.max (at the top of the file).
  const auto no_domain = issuesOf("simulation:\n  duration: 1\n");
  REQUIRE_ISSUE(no_domain, 1, 1, "missing required key 'domain.min'");
  REQUIRE_ISSUE(no_domain, 1, 1, "missing required key 'domain.max'");

  // An empty file has no location to give.
  const auto empty = issuesOf("");
  REQUIRE(empty.size() == 2);
  CHECK(empty[0].line == 0);
}

TEST_CASE("YAML syntax errors carry their location", "[io]") {
  const std::string yaml =
      "simulation:\n"          // 1
      "  duration: 1\n"        // 2
      " frame_rate: 30\n";     // 3   bad indentation: yaml-cpp stops at 3:2
  const auto issues = issuesOf(yaml);
  REQUIRE(issues.size() == 1);
  REQUIRE_ISSUE(issues, 3, 2, "YAML syntax error");

  const auto flow = issuesOf("domain:\n  min: [0, 0, 0\n");
  REQUIRE(flow.size() == 1);
  CHECK(flow[0].message.find("YAML syntax error") != std::string::npos);
  CHECK(flow[0].line > 0);

  // A document that is not a map.
  const auto list = issuesOf("- 1\n- 2\n");
  REQUIRE_ISSUE(list, 1, 1, "a scene must be a map");
}

TEST_CASE("blocks and inflows must name a defined phase", "[io]") {
  const std::string yaml =
      kDomain +                            // 1
      "fluid:\n"                           // 2
      "  phases:\n"                        // 3
      "    - name: water\n"                // 4
      "    - name: honey\n"                // 5
      "  blocks:\n"                        // 6
      "    - phase: hony\n"                // 7   col 14
      "      min: [0, 0, 0]\n"             // 8
      "      max: [0.5, 0.5, 0.5]\n"       // 9
      "  inflows:\n"                       // 10
      "    - phase: oil\n"                 // 11  col 14
      "      position: [0.5, 0.5, 0.9]\n"; // 12
  const auto issues = issuesOf(yaml);
  REQUIRE_ISSUE(issues, 7, 14, "undefined phase 'hony'", "defined phases: water, honey", "did you mean 'honey'?");
  REQUIRE_ISSUE(issues, 11, 14, "undefined phase 'oil'");
  CHECK(issues.size() == 2);
}

TEST_CASE("checks across keys: domain, blocks, inflows, phase names", "[io]") {
  const std::string yaml =
      "domain:\n"                              // 1
      "  min: [0, 0, 0]\n"                     // 2
      "  max: [1, 1, 1]\n"                     // 3
      "fluid:\n"                               // 4
      "  phases:\n"                            // 5
      "    - name: water\n"                    // 6
      "    - name: water\n"                    // 7   col 13: duplicate
      "  blocks:\n"                            // 8
      "    - min: [0.5, 0, 0]\n"               // 9
      "      max: [0.4, 1, 1]\n"               // 10  col 12: max < min in x
      "    - min: [0, 0, 0]\n"                 // 11  col 7: item outside the domain
      "      max: [1, 1, 1.5]\n"               // 12
      "  inflows:\n"                           // 13
      "    - position: [2, 0.5, 0.5]\n"        // 14  col 17: outside the domain
      "      direction: [0, 0, 0]\n"           // 15  col 18: zero
      "      start: 1\n"                       // 16
      "      stop: 0.5\n";                     // 17  col 13: stop <= start
  const auto issues = issuesOf(yaml);
  REQUIRE_ISSUE(issues, 7, 13, "duplicate phase name 'water'");
  REQUIRE_ISSUE(issues, 10, 12, "'fluid.blocks[0].max' [0.4, 1, 1] must be greater than 'fluid.blocks[0].min'");
  REQUIRE_ISSUE(issues, 11, 7, "block fluid.blocks[1]", "is not inside the domain");
  REQUIRE_ISSUE(issues, 14, 17, "'fluid.inflows[0].position' [2, 0.5, 0.5] is outside the domain");
  REQUIRE_ISSUE(issues, 15, 18, "'fluid.inflows[0].direction' must be nonzero");
  REQUIRE_ISSUE(issues, 17, 13, "'fluid.inflows[0].stop' = 0.5 must be greater than 'fluid.inflows[0].start' = 1");
  CHECK(issues.size() == 6);

  const auto bad_domain = issuesOf("domain:\n  min: [0, 0, 1]\n  max: [1, 1, 1]\n");
  REQUIRE_ISSUE(bad_domain, 3, 8, "'domain.max' [1, 1, 1] must be greater than 'domain.min' [0, 0, 1]");

  const auto no_phases = issuesOf(kDomain + "fluid:\n  phases: []\n");
  REQUIRE_ISSUE(no_phases, 3, 11, "at least one phase");
}

TEST_CASE("duplicate keys are reported", "[io]") {
  const auto issues = issuesOf(kDomain + "simulation:\n  cfl: 0.3\n  cfl: 0.2\n");
  REQUIRE_ISSUE(issues, 4, 3, "duplicate key 'cfl' (first given at line 3)");
}

TEST_CASE("a missing scene file is an InputError naming the path", "[io]") {
  const std::string path = (fs::temp_directory_path() / "sphaptics_no_such_dir" / "scene.yaml").string();
  try {
    loadScene(path);
    FAIL("expected an InputError");
  } catch (const InputError& e) {
    REQUIRE(e.issues().size() == 1);
    CHECK(e.issues()[0].file == path);
    CHECK(e.issues()[0].line == 0);
    CHECK(e.issues()[0].message.find("cannot open the scene file") != std::string::npos);
    CHECK(std::string(e.what()).find(path) != std::string::npos);
  }
}

TEST_CASE("scene files: absolute source_file, output.directory relative to the scene", "[io]") {
  TempDir dir;
  fs::create_directories(dir.path / "scenes");
  const fs::path file = dir.path / "scenes" / "tank.yaml";
  std::ofstream(file) << kDomain << "output:\n  directory: ../results/tank\n";
  const SceneSpec s = loadScene(file.string());
  CHECK(s.source_file == file.lexically_normal().string());
  CHECK(s.output.directory == (dir.path / "results" / "tank").lexically_normal().string());
  CHECK(s.domain.loc.file == file.string());
  CHECK(s.domain.loc.line == 1);

  // Given with --set, the directory is relative to the working directory, like any CLI path.
  const SceneSpec o = loadScene(file.string(), {"output.directory=elsewhere"});
  CHECK(o.output.directory == (fs::current_path() / "elsewhere").lexically_normal().string());

  // Errors name the file as it was given.
  std::ofstream(file) << kDomain << "simulation:\n  cfl: 2\n";
  try {
    loadScene(file.string());
    FAIL("expected an InputError");
  } catch (const InputError& e) {
    REQUIRE(e.issues().size() == 1);
    CHECK(e.issues()[0].str().rfind(file.string() + ":3:8: 'simulation.cfl' = 2 is out of range", 0) == 0);
  }
}

// ---------------------------------------------------------------------------------------------
// --set overrides
// ---------------------------------------------------------------------------------------------

TEST_CASE("Overrides from --set are applied before validation", "[io]") {
  const std::string yaml =
      kDomain +
      "fluid:\n"
      "  phases:\n"
      "    - name: water\n"
      "    - name: oil\n"
      "      rest_density: 900\n";
  const SceneSpec s = loadSceneFromString(yaml, "scene.yaml",
                                          {"simulation.gravity=[0, 0, -1]", "simulation.kernel=wendland_c2",
                                           "fluid.phases[1].viscosity=1e-3", "fluid.phases[0].rest_density = 998",
                                           "domain.closed.z_max=true", "fluid.particle_spacing=0.05",
                                           "simulation.duration=1", "simulation.duration=3"});
  CHECK(s.simulation.gravity == Eigen::Vector3d(0, 0, -1));  // flow lists work
  CHECK(s.simulation.kernel == sph::KernelType::WendlandC2);
  CHECK(s.fluid.phases[1].viscosity == 1e-3);
  CHECK(s.fluid.phases[1].rest_density == 900.0);
  CHECK(s.fluid.phases[0].rest_density == 998.0);
  CHECK(s.domain.closed[sph::ZMax]);
  CHECK(s.fluid.particle_spacing == 0.05);
  CHECK(s.simulation.duration == 3.0);  // the last one wins
  CHECK(s.simulation.loc.line == 0);  // the section was created by the override: no place in the file

  // Whole lists can be replaced, and a scene can even be built from overrides alone.
  const SceneSpec b = loadSceneFromString("", "empty.yaml",
                                          {"domain.min=[0,0,0]", "domain.max=[2,1,1]", "fluid.phases=[{name: oil}]"});
  CHECK(b.domain.max == Eigen::Vector3d(2, 1, 1));
  REQUIRE(b.fluid.phases.size() == 1);
  CHECK(b.fluid.phases[0].name == "oil");
}

TEST_CASE("bad --set keys and values are InputErrors against '--set'", "[io]") {
  const std::string yaml = kDomain + "fluid:\n  phases:\n    - name: water\n";

  const auto unknown = issuesOf(yaml, {"fluid.particle_spaceing=0.01"});
  REQUIRE(unknown.size() == 1);
  REQUIRE_SET_ISSUE(unknown, "'fluid.particle_spaceing=0.01'", "unknown key 'fluid.particle_spaceing'",
                    "did you mean 'fluid.particle_spacing'?");
  CHECK(unknown[0].str().rfind("--set: ", 0) == 0);

  const auto nested = issuesOf(yaml, {"fluid.phases[0].viscosty=1"});
  REQUIRE_SET_ISSUE(nested, "did you mean 'fluid.phases[0].viscosity'?");

  const auto section = issuesOf(yaml, {"simulaton.cfl=0.3"});
  REQUIRE_SET_ISSUE(section, "did you mean 'simulation.cfl'?");

  const auto nonsense = issuesOf(yaml, {"zzz=1"});
  REQUIRE_SET_ISSUE(nonsense, "unknown key 'zzz'", "known keys at the top level: simulation, domain, fluid, rigid_bodies, cloth, soft_bodies, probes, output");

  REQUIRE_SET_ISSUE(issuesOf(yaml, {"simulation.cfl"}), "expected key.path=value");
  REQUIRE_SET_ISSUE(issuesOf(yaml, {"simulation.gravity.x=1"}), "has no sub-keys");
  REQUIRE_SET_ISSUE(issuesOf(yaml, {"fluid.phases.viscosity=1"}), "address an item as fluid.phases[0]");
  REQUIRE_SET_ISSUE(issuesOf(yaml, {"fluid.phases[3].viscosity=1"}), "'fluid.phases' has 1 item(s)");
  REQUIRE_SET_ISSUE(issuesOf(yaml, {"simulation.gravity=[0, 0"}), "cannot parse the value as YAML");

  // Bad values are validated like scene values and reported against the override.
  const auto value = issuesOf(yaml, {"simulation.cfl=abc", "fluid.phases[0].colour=[1, 2, 0]"});
  REQUIRE_SET_ISSUE(value, "'simulation.cfl=abc'", "'simulation.cfl' must be a number");
  REQUIRE_SET_ISSUE(value, "'fluid.phases[0].colour=[1, 2, 0]'", "'fluid.phases[0].colour[1]' = 2 is out of range");

  // A broken phase item is reported once, without follow-up errors about references to it.
  const auto item = issuesOf(yaml + "  blocks:\n    - {phase: water, min: [0, 0, 0], max: [1, 1, 1]}\n", {"fluid.phases[0]=bar"});
  REQUIRE(item.size() == 1);
  REQUIRE_SET_ISSUE(item, "each item of 'fluid.phases' must be a map");

  // Override problems and file problems come together in one error.
  const auto both = issuesOf(yaml + "output:\n  particls: true\n", {"simulation.frame_rat=30"});
  REQUIRE(both.size() == 2);
  REQUIRE_SET_ISSUE(both, "did you mean 'simulation.frame_rate'?");
  REQUIRE_ISSUE(both, 6, 3, "did you mean 'particles'?");
}

// ---------------------------------------------------------------------------------------------
// Schema text and JSON
// ---------------------------------------------------------------------------------------------

TEST_CASE("the schema text lists every key with type, default, unit and range", "[io]") {
  const std::string text = sph::io::schemaText();
  // Every key of the YAML format, as the design lists them.
  const std::vector<std::string> expected = {
      "simulation", "simulation.duration", "simulation.frame_rate", "simulation.substeps", "simulation.gravity",
      "simulation.gravity_ramp", "simulation.settle_time", "simulation.settle_damping", "simulation.kernel", "simulation.support_ratio", "simulation.time_step_control",
      "simulation.cfl", "simulation.contact_step", "simulation.numerical_errors", "domain", "domain.min", "domain.max", "domain.closed",
      "domain.closed.x_min", "domain.closed.x_max", "domain.closed.y_min", "domain.closed.y_max",
      "domain.closed.z_min", "domain.closed.z_max", "domain.boundary_layers", "fluid", "fluid.solver", "fluid.dfsph",
      "fluid.dfsph.density_error", "fluid.dfsph.divergence_error", "fluid.dfsph.min_iterations",
      "fluid.dfsph.max_iterations", "fluid.dfsph.divergence_min_iterations", "fluid.dfsph.divergence_max_iterations",
      "fluid.dfsph.divergence_solve", "fluid.dfsph.walls", "fluid.dfsph.warm_start", "fluid.dfsph.warm_smoothing", "fluid.dfsph.warm_average", "fluid.dfsph.warm_average_rest", "fluid.dfsph.relaxation", "fluid.dfsph.chebyshev", "fluid.dfsph.divergence_chebyshev", "fluid.dfsph.viscosity_solve", "fluid.dfsph.viscosity_tolerance", "fluid.dfsph.viscosity_max_iterations", "fluid.dfsph.coarse_interval", "fluid.dfsph.coarse_start", "fluid.dfsph.coarse_rest_travel", "fluid.dfsph.coarse_reuse", "fluid.dfsph.coarse_rest_start", "fluid.dfsph.cfl", "fluid.dfsph.max_time_step", "fluid.dfsph.step_iterations", "fluid.dfsph.pressure_cfl", "fluid.dfsph.body_added_mass", "fluid.dfsph.cloth_coupling", "fluid.dfsph.body_coupling", "fluid.dfsph.body_error", "fluid.dfsph.body_coarse", "fluid.dfsph.cloth_added_mass",
      "fluid.particle_spacing",
      "fluid.equation_of_state", "fluid.speed_of_sound", "fluid.viscosity_model", "fluid.artificial_viscosity",
      "fluid.body_viscosity", "fluid.body_ambient_pressure", "fluid.boundary_velocity", "fluid.colour_diffusion", "fluid.clamp_negative_pressure", "fluid.background_pressure", "fluid.max_particles", "fluid.phases",
      "fluid.phases[].name", "fluid.phases[].rest_density", "fluid.phases[].viscosity", "fluid.phases[].colour",
      "fluid.blocks", "fluid.blocks[].phase", "fluid.blocks[].min", "fluid.blocks[].max", "fluid.blocks[].velocity",
      "fluid.inflows", "fluid.inflows[].name", "fluid.inflows[].phase", "fluid.inflows[].shape",
      "fluid.inflows[].position", "fluid.inflows[].direction", "fluid.inflows[].radius", "fluid.inflows[].width",
      "fluid.inflows[].height", "fluid.inflows[].speed", "fluid.inflows[].start", "fluid.inflows[].stop",
      "rigid_bodies", "rigid_bodies[].name", "rigid_bodies[].shape", "rigid_bodies[].mesh", "rigid_bodies[].radius",
      "rigid_bodies[].size", "rigid_bodies[].height", "rigid_bodies[].position", "rigid_bodies[].orientation_axis",
      "rigid_bodies[].orientation_angle", "rigid_bodies[].scale", "rigid_bodies[].density", "rigid_bodies[].mass",
      "rigid_bodies[].dynamic", "rigid_bodies[].hold_until", "rigid_bodies[].velocity", "rigid_bodies[].angular_velocity",
      "rigid_bodies[].friction", "rigid_bodies[].restitution", "rigid_bodies[].colour", "rigid_bodies[].grabbable",
      "rigid_bodies[].cutter",
      "rigid_bodies[].motion", "rigid_bodies[].motion.type", "rigid_bodies[].motion.velocity",
      "rigid_bodies[].motion.angular_velocity", "rigid_bodies[].motion.keyframes", "rigid_bodies[].motion.keyframes[].time",
      "rigid_bodies[].motion.keyframes[].position", "rigid_bodies[].motion.keyframes[].orientation_axis",
      "rigid_bodies[].motion.keyframes[].orientation_angle", "cloth", "cloth[].name", "cloth[].width",
      "cloth[].length", "cloth[].resolution_x", "cloth[].resolution_y", "cloth[].position", "cloth[].orientation_axis",
      "cloth[].orientation_angle", "cloth[].areal_density", "cloth[].stretch_stiffness", "cloth[].shear_stiffness",
      "cloth[].bend_stiffness", "cloth[].damping", "cloth[].air_damping", "cloth[].solver", "cloth[].iterations", "cloth[].max_time_step",
      "cloth[].tear_strain", "cloth[].prestrain", "cloth[].colour", "cloth[].mesh", "cloth[].anchors", "cloth[].anchors[].type", "cloth[].anchors[].edge",
      "cloth[].anchors[].i", "cloth[].anchors[].j", "cloth[].anchors[].min", "cloth[].anchors[].max",
      "cloth[].anchors[].velocity", "cloth[].anchors[].stop", "cloth[].anchors[].keyframes",
      "cloth[].anchors[].keyframes[].time", "cloth[].anchors[].keyframes[].offset", "soft_bodies", "soft_bodies[].name",
      "soft_bodies[].size", "soft_bodies[].position", "soft_bodies[].orientation_axis", "soft_bodies[].orientation_angle",
      "soft_bodies[].spacing", "soft_bodies[].density", "soft_bodies[].young_modulus", "soft_bodies[].damping",
      "soft_bodies[].air_damping", "soft_bodies[].solver", "soft_bodies[].iterations", "soft_bodies[].max_time_step", "soft_bodies[].tear_strain",
      "soft_bodies[].prestrain", "soft_bodies[].colour", "soft_bodies[].mesh", "soft_bodies[].anchors",
      "soft_bodies[].anchors[].type", "soft_bodies[].anchors[].edge", "soft_bodies[].anchors[].i",
      "soft_bodies[].anchors[].j", "soft_bodies[].anchors[].k", "soft_bodies[].anchors[].min",
      "soft_bodies[].anchors[].max", "soft_bodies[].anchors[].velocity", "soft_bodies[].anchors[].stop",
      "soft_bodies[].anchors[].keyframes", "soft_bodies[].anchors[].keyframes[].time",
      "soft_bodies[].anchors[].keyframes[].offset", "probes", "probes.rate", "probes.points",
      "probes.points[].name", "probes.points[].position", "probes.gauges", "probes.gauges[].name",
      "probes.gauges[].position", "probes.gauges[].length", "output", "output.directory", "output.particles",
      "output.step_forces",
      "output.isosurface", "output.isosurface.enabled", "output.isosurface.spacing", "output.isosurface.iso",
      "output.isosurface.vertex_colours", "output.isosurface.obj", "output.isosurface.vdb", "output.isosurface.vdb_level_set",
      "haptics", "haptics.backend", "haptics.scale", "haptics.rotation_axis", "haptics.rotation_angle", "haptics.offset", "haptics.gain", "haptics.stiffness", "haptics.damping", "haptics.damping_ratio", "haptics.reach", "haptics.hold_orientation", "haptics.peak_force", "haptics.continuous_force", "haptics.ramp_time", "haptics.watchdog", "haptics.lowpass", "haptics.passivity", "haptics.servo_rate", "haptics.smoothing", "haptics.rolling_window", "haptics.hand_mass", "haptics.hand_stiffness", "haptics.hand_damping", "haptics.bridge_port", "haptics.listen_port", "haptics.bridge_timeout", "haptics.path", "haptics.path[].type", "haptics.path[].start", "haptics.path[].end", "haptics.path[].from", "haptics.path[].to", "haptics.path[].centre", "haptics.path[].radius", "haptics.path[].axis", "haptics.path[].period", "haptics.path[].phase", "haptics.path[].amplitude", "haptics.path[].f0", "haptics.path[].f1", "haptics.waypoints", "haptics.waypoints[].time", "haptics.waypoints[].position", "haptics.buttons", "haptics.buttons[].time", "haptics.buttons[].button", "haptics.buttons[].pressed"};
  const auto& table = sph::io::schemaTable();
  REQUIRE(table.size() == expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    INFO(expected[i]);
    CHECK(table[i].path == expected[i]);
    CHECK(text.find("\n" + expected[i] + " ") != std::string::npos);  // one row per key, key first
  }
  // Rows carry type, default, unit and allowed values.
  CHECK(text.find("simulation.cfl") != std::string::npos);
  auto row = [&](const std::string& key) {
    const auto at = text.find("\n" + key + " ");
    return text.substr(at + 1, text.find('\n', at + 1) - at - 1);
  };
  CHECK(row("simulation.cfl").find("float") != std::string::npos);
  CHECK(row("simulation.cfl").find("0.4") != std::string::npos);
  CHECK(row("simulation.cfl").find("(0, 1]") != std::string::npos);
  CHECK(row("fluid.phases[].rest_density").find("kg/m^3") != std::string::npos);
  CHECK(row("simulation.kernel").find("cubic_spline|wendland_c2") != std::string::npos);
  CHECK(row("domain.max").find("(required)") != std::string::npos);
  // Aligned: the type column starts at the same offset in every row.
  const auto offset = row("simulation").find("map");
  CHECK(row("output.particles").find("bool") == offset);
  CHECK(row("fluid.inflows[].stop").find("float") == offset);
}

TEST_CASE("sceneToJson writes every key of the resolved scene", "[io]") {
  const std::string yaml =
      kDomain +
      "fluid:\n"
      "  phases:\n"
      "    - name: \"a \\\"quoted\\\" name\"\n"
      "  inflows:\n"
      "    - position: [0.5, 0.5, 0.5]\n";
  const SceneSpec s = loadSceneFromString(yaml, "scene.yaml");
  const std::string json = sph::io::sceneToJson(s);
  INFO(json);
  // Every key name of the table appears (list items because the scene has one of each but blocks,
  // bodies, cloths, soft bodies and the haptic path, waypoints and buttons).
  for (const auto& key : sph::io::schemaTable()) {
    if (key.path.rfind("fluid.blocks[]", 0) == 0 || key.path.rfind("rigid_bodies[]", 0) == 0 ||
        key.path.rfind("probes.points[]", 0) == 0 || key.path.rfind("probes.gauges[]", 0) == 0 ||
        key.path.rfind("haptics.path[]", 0) == 0 || key.path.rfind("haptics.waypoints[]", 0) == 0 ||
        key.path.rfind("haptics.buttons[]", 0) == 0 || key.path.rfind("cloth[]", 0) == 0 ||
        key.path.rfind("soft_bodies[]", 0) == 0)
      continue;
    CHECK(json.find("\"" + key.name() + "\":") != std::string::npos);
  }
  CHECK(json.find("\"source_file\": ") != std::string::npos);
  CHECK(json.find("\"duration\": 2,") != std::string::npos);
  CHECK(json.find("\"gravity\": [0, 0, -9.81]") != std::string::npos);
  CHECK(json.find("\"kernel\": \"cubic_spline\"") != std::string::npos);
  CHECK(json.find("\"stop\": \"inf\"") != std::string::npos);   // infinity is written as the string "inf"
  CHECK(json.find("\"blocks\": []") != std::string::npos);
  CHECK(json.find("\"name\": \"a \\\"quoted\\\" name\"") != std::string::npos);
  CHECK(json.find("\"phase\": \"a \\\"quoted\\\" name\"") != std::string::npos);  // resolved default phase
  CHECK(json.find("\"clamp_negative_pressure\": true") != std::string::npos);
  // Balanced brackets outside strings.
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < json.size(); ++i) {
    const char c = json[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
    } else if (c == '"') in_string = true;
    else if (c == '{' || c == '[') ++depth;
    else if (c == '}' || c == ']') CHECK(--depth >= 0);
  }
  CHECK(depth == 0);
  CHECK_FALSE(in_string);
}
