// The command line as a user meets it: the real `sphaptics` executable (SPHAPTICS_BINARY) run
// through the shell, its exit code and its stderr. Bad input of every kind gives exit code 2 and a
// message with file:line:col, and a run that fails leaves no particles.h5part behind; validate,
// schema, devices and --version work. Apart from one single-frame run, nothing here simulates.
//
// The bad scenes below are written one line per string literal with the line number in a comment,
// so that the expected locations can be read off the source. Each command runs inside the test's
// temporary folder, so messages name the scene file as it was given ("bad.yaml:5:7: ...").
#include "tests/run_binary.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const fs::path kSourceDir = SPHAPTICS_SOURCE_DIR;
const fs::path kTinyScene = kSourceDir / "scenes" / "tests" / "tiny_tank.yaml";

using sph::testing::TempDir;
using sph::testing::readFile;
using sph::testing::Result;
using sph::testing::sphaptics;

bool contains(const std::string& text, const std::string& fragment) {
  return text.find(fragment) != std::string::npos;
}

/// Lines of `text` that start with `prefix`.
int countLines(const std::string& text, const std::string& prefix) {
  std::istringstream in(text);
  int n = 0;
  for (std::string line; std::getline(in, line);) n += line.rfind(prefix, 0) == 0 ? 1 : 0;
  return n;
}

/// No output that looks like a finished run: no particles.h5part (nor a .partial of one),
/// and a run.json, if any, does not say "complete".
void requireNoCompleteOutput(const fs::path& out) {
  INFO("output folder " << out);
  CHECK_FALSE(fs::exists(out / "particles.h5part"));
  CHECK_FALSE(fs::exists(out / "particles.h5part.partial"));
  if (fs::exists(out / "run.json")) CHECK_FALSE(contains(readFile(out / "run.json"), "\"status\": \"complete\""));
}

/// `validate` and `run` on the same bad scene both exit with 2 and print every fragment;
/// the failed run leaves no particle output in its --out folder.
void requireBadScene(const TempDir& tmp, const std::string& file, const std::vector<std::string>& fragments) {
  const Result v = sphaptics(tmp.path, {"validate", file});
  INFO("validate " << file << " -> exit " << v.code << ", stderr:\n" << v.err);
  CHECK(v.code == 2);
  for (const auto& f : fragments) CHECK(contains(v.err, f));

  const Result r = sphaptics(tmp.path, {"run", file, "--out", "out", "--quiet"});
  INFO("run " << file << " -> exit " << r.code << ", stderr:\n" << r.err);
  CHECK(r.code == 2);
  for (const auto& f : fragments) CHECK(contains(r.err, f));
  requireNoCompleteOutput(tmp.path / "out");
}

const std::string kDomain = "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n";

}  // namespace

// ---------------------------------------------------------------------------------------------
// Bad scene files: exit code 2, file:line:col, no output
// ---------------------------------------------------------------------------------------------

TEST_CASE("cli: an unknown key is reported with its location and a suggestion", "[cli]") {
  TempDir tmp;
  tmp.write("bad.yaml",
            kDomain +                  // 1
            "fluid:\n"                 // 2
            "  phases:\n"              // 3
            "    - name: water\n"      // 4
            "      viscosty: 1e-3\n"); // 5  col 7
  requireBadScene(tmp, "bad.yaml", {"bad.yaml:5:7: unknown key 'viscosty'", "(did you mean 'viscosity'?)"});
}

TEST_CASE("cli: a value of the wrong type is reported with its location", "[cli]") {
  TempDir tmp;
  tmp.write("bad.yaml",
            "simulation:\n"            // 1
            "  duration: fast\n"       // 2  col 13
            + kDomain);                // 3
  requireBadScene(tmp, "bad.yaml", {"bad.yaml:2:13: 'simulation.duration' must be a number (unit: s), got 'fast'"});
}

TEST_CASE("cli: an out-of-range value is reported with its location and range", "[cli]") {
  TempDir tmp;
  tmp.write("bad.yaml",
            kDomain +                          // 1
            "fluid:\n"                         // 2
            "  particle_spacing: -0.01\n");    // 3  col 21
  requireBadScene(tmp, "bad.yaml",
                  {"bad.yaml:3:21: 'fluid.particle_spacing' = -0.01 is out of range (must be > 0, unit: m)"});
}

TEST_CASE("cli: a bad enum value lists the allowed values", "[cli]") {
  TempDir tmp;
  tmp.write("bad.yaml",
            "simulation:\n"                 // 1
            "  kernel: cubic\n"             // 2  col 11
            + kDomain);                     // 3
  requireBadScene(tmp, "bad.yaml",
                  {"bad.yaml:2:11: 'simulation.kernel' = 'cubic' is not allowed",
                   "allowed values: cubic_spline, wendland_c2"});
}

TEST_CASE("cli: a missing required key is reported at its section", "[cli]") {
  TempDir tmp;
  tmp.write("bad.yaml",
            "domain:\n"                 // 1  col 1: domain.max missing
            "  min: [0, 0, 0]\n");      // 2
  requireBadScene(tmp, "bad.yaml", {"bad.yaml:1:1: missing required key 'domain.max'"});
}

TEST_CASE("cli: a YAML syntax error is reported with its location", "[cli]") {
  TempDir tmp;
  tmp.write("bad.yaml",
            "simulation:\n"            // 1
            "  duration: 1\n"          // 2
            " frame_rate: 30\n");      // 3  bad indentation: yaml-cpp stops at col 2
  requireBadScene(tmp, "bad.yaml", {"bad.yaml:3:2: YAML syntax error"});
}

TEST_CASE("cli: a block naming an undefined phase is reported with the defined phases", "[cli]") {
  TempDir tmp;
  tmp.write("bad.yaml",
            kDomain +                        // 1
            "fluid:\n"                       // 2
            "  phases:\n"                    // 3
            "    - name: water\n"            // 4
            "    - name: honey\n"            // 5
            "  blocks:\n"                    // 6
            "    - phase: hony\n"            // 7  col 14
            "      min: [0, 0, 0]\n"         // 8
            "      max: [0.5, 0.5, 0.5]\n"); // 9
  requireBadScene(tmp, "bad.yaml",
                  {"bad.yaml:7:14: undefined phase 'hony'", "defined phases: water, honey", "did you mean 'honey'?"});
}

TEST_CASE("cli: every error of a file is reported, not just the first", "[cli]") {
  TempDir tmp;
  tmp.write("bad.yaml",
            "simulation:\n"                    // 1
            "  duration: fast\n"               // 2  col 13: wrong type
            "  kernel: cubic\n"                // 3  col 11: bad enum
            "domain:\n"                        // 4
            "  min: [0, 0, 0]\n"               // 5
            "  max: [1, 1, 1]\n"               // 6
            "fluid:\n"                         // 7
            "  particle_spacing: -0.01\n"      // 8  col 21: out of range
            "  blocs: []\n");                  // 9  col 3: unknown key
  const std::vector<std::string> errors = {
      "bad.yaml:2:13: 'simulation.duration' must be a number",
      "bad.yaml:3:11: 'simulation.kernel' = 'cubic' is not allowed",
      "bad.yaml:8:21: 'fluid.particle_spacing' = -0.01 is out of range",
      "bad.yaml:9:3: unknown key 'blocs'",
  };
  requireBadScene(tmp, "bad.yaml", errors);

  // One line per error, and nothing else reported as an error.
  const Result v = sphaptics(tmp.path, {"validate", "bad.yaml"});
  INFO(v.err);
  CHECK(countLines(v.err, "error: ") == 4);

  // validate goes on to the next file after a bad one, and still exits with 2.
  tmp.write("good.yaml", kDomain + "fluid: {blocks: [{min: [0, 0, 0], max: [0.2, 0.2, 0.2]}]}\n");
  const Result both = sphaptics(tmp.path, {"validate", "bad.yaml", "good.yaml"});
  INFO(both.out << both.err);
  CHECK(both.code == 2);
  CHECK(contains(both.out, "good.yaml: ok"));
  CHECK(countLines(both.err, "error: ") == 4);
}

TEST_CASE("cli: a missing scene file is bad input naming the path", "[cli]") {
  TempDir tmp;
  requireBadScene(tmp, "no_such_scene.yaml", {"no_such_scene.yaml", "cannot open the scene file"});
}

// ---------------------------------------------------------------------------------------------
// Bad command lines: exit code 2, the option named, no output
// ---------------------------------------------------------------------------------------------

TEST_CASE("cli: an unknown --disable stage lists the stages", "[cli]") {
  TempDir tmp;
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--disable", "presure"});
  INFO("exit " << r.code << ", stderr:\n" << r.err);
  CHECK(r.code == 2);
  CHECK(contains(r.err, "--disable: unknown stage 'presure'"));
  CHECK(contains(r.err, "inflow, grid, density, probes, pressure, divergence_solve, viscosity, colour_diffusion, density_solve, "
                               "rigid_coupling, haptics, cloth_coupling, integrate, rigid_dynamics, cloth, diagnostics"));
  requireNoCompleteOutput(tmp.path / "out");
}

TEST_CASE("cli: a bad --set key or value is bad input naming --set", "[cli]") {
  TempDir tmp;
  SECTION("unknown key, with a suggestion") {
    const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--set",
                                          "fluid.particle_spacng=0.01"});
    INFO("exit " << r.code << ", stderr:\n" << r.err);
    CHECK(r.code == 2);
    CHECK(contains(r.err, "--set: 'fluid.particle_spacng=0.01': unknown key 'fluid.particle_spacng'"));
    CHECK(contains(r.err, "did you mean 'fluid.particle_spacing'?"));
  }
  SECTION("value of the wrong type") {
    const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--set",
                                          "fluid.particle_spacing=abc"});
    INFO("exit " << r.code << ", stderr:\n" << r.err);
    CHECK(r.code == 2);
    CHECK(contains(r.err, "--set: 'fluid.particle_spacing=abc': 'fluid.particle_spacing' must be a number"));
  }
  SECTION("out-of-range --duration") {
    const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--duration", "0"});
    INFO("exit " << r.code << ", stderr:\n" << r.err);
    CHECK(r.code == 2);
    CHECK(contains(r.err, "--duration: must be > 0"));
  }
  requireNoCompleteOutput(tmp.path / "out");
}

TEST_CASE("cli: an --out folder that cannot be created is bad input", "[cli]") {
  TempDir tmp;
  tmp.write("taken", "a file where the output folder's parent should be\n");
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "taken/out", "--quiet"});
  INFO("exit " << r.code << ", stderr:\n" << r.err);
  CHECK(r.code == 2);
  CHECK(contains(r.err, "taken/out"));
  CHECK(contains(r.err, "cannot create the output folder"));
  CHECK(readFile(tmp.path / "taken") == "a file where the output folder's parent should be\n");
}

TEST_CASE("cli: unknown options and a missing command exit with 2", "[cli]") {
  TempDir tmp;
  const Result flag = sphaptics(tmp.path, {"run", kTinyScene.string(), "--bogus"});
  INFO(flag.err);
  CHECK(flag.code == 2);
  CHECK(contains(flag.err, "--bogus"));
  const Result none = sphaptics(tmp.path, {});
  INFO(none.err);
  CHECK(none.code == 2);
  const Result unknown = sphaptics(tmp.path, {"simulate"});
  INFO(unknown.err);
  CHECK(unknown.code == 2);
  // the force bench's solver and check-group names are checked before anything runs
  const Result group = sphaptics(tmp.path, {"bench", "--forces-only", "--force-checks", "stoke"});
  INFO(group.err);
  CHECK(group.code == 2);
  CHECK(contains(group.err, "stoke"));
  const Result solver = sphaptics(tmp.path, {"bench", "--forces-only", "--force-solvers", "dfsph-gost"});
  INFO(solver.err);
  CHECK(solver.code == 2);
  CHECK(contains(solver.err, "dfsph-gost"));
  // the accuracy runs' scene overrides are checked before anything runs, as run --set's
  const Result set = sphaptics(tmp.path, {"bench", "--accuracy-only", "--no-impact", "--accuracy-set",
                                          "fluid.artificial_viscosty=0"});
  INFO(set.err);
  CHECK(set.code == 2);
  CHECK(contains(set.err, "did you mean 'fluid.artificial_viscosity'"));
  const Result range = sphaptics(tmp.path, {"bench", "--accuracy-only", "--no-impact", "--accuracy-set",
                                            "fluid.artificial_viscosity=-1"});
  INFO(range.err);
  CHECK(range.code == 2);
  CHECK(contains(range.err, "out of range"));
  CHECK_FALSE(fs::exists(tmp.path / "bench" / "accuracy.csv"));
}

// ---------------------------------------------------------------------------------------------
// The commands that work
// ---------------------------------------------------------------------------------------------

TEST_CASE("cli: validate accepts every scene shipped in scenes/", "[cli]") {
  TempDir tmp;
  std::vector<std::string> scenes;
  for (const auto& e : fs::recursive_directory_iterator(kSourceDir / "scenes"))
    if (e.is_regular_file() && e.path().extension() == ".yaml") scenes.push_back(e.path().string());
  REQUIRE(scenes.size() >= 2);  // at least scenes/dam_break.yaml and scenes/tests/tiny_tank.yaml
  for (const auto& scene : scenes) {
    const Result r = sphaptics(tmp.path, {"validate", scene});
    INFO(scene << " -> exit " << r.code << "\n" << r.out << r.err);
    CHECK(r.code == 0);
    CHECK(contains(r.out, scene + ": ok"));
  }
}

TEST_CASE("cli: schema lists every key with its type, unit and range", "[cli]") {
  TempDir tmp;
  const Result r = sphaptics(tmp.path, {"schema"});
  INFO(r.err);
  REQUIRE(r.code == 0);

  // The row of a key, split into whitespace-separated words.
  auto row = [&](const std::string& key) {
    std::istringstream in(r.out);
    for (std::string line; std::getline(in, line);) {
      std::istringstream words(line);
      std::vector<std::string> w;
      for (std::string s; words >> s;) w.push_back(s);
      if (!w.empty() && w[0] == key) return w;
    }
    return std::vector<std::string>{};
  };
  // KEY TYPE DEFAULT UNIT ALLOWED DESCRIPTION
  const auto spacing = row("fluid.particle_spacing");
  INFO(r.out);
  REQUIRE(spacing.size() >= 5);
  CHECK(spacing[1] == "float");
  CHECK(spacing[3] == "m");
  const auto kernel = row("simulation.kernel");
  REQUIRE(kernel.size() >= 4);
  CHECK(kernel[1] == "enum");
  CHECK(contains(r.out, "cubic_spline|wendland_c2"));
  const auto max = row("domain.max");
  REQUIRE(max.size() >= 4);
  CHECK(max[1] == "vec3");
  CHECK(max[2] == "(required)");
  CHECK(max[3] == "m");
  CHECK_FALSE(row("fluid.phases[].rest_density").empty());
  CHECK_FALSE(row("output.particles").empty());
}

TEST_CASE("cli: --version prints the version", "[cli]") {
  TempDir tmp;
  const Result r = sphaptics(tmp.path, {"--version"});
  INFO(r.err);
  CHECK(r.code == 0);
  CHECK(contains(r.out, std::string("sphaptics ") + SPHAPTICS_VERSION));
}

TEST_CASE("cli: devices lists at least one OpenCL device", "[cli]") {
  TempDir tmp;
  const Result r = sphaptics(tmp.path, {"devices"});
  INFO(r.out << r.err);
  CHECK(r.code == 0);
  CHECK(countLines(r.out, "device 0: ") == 1);
}

TEST_CASE("cli: a complete run writes particles.h5part and a run.json that says complete", "[cli]") {
  // The counterpart of the failed runs above: one frame of the tiny tank on the CPU.
  TempDir tmp;
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--device", "cpu",
                                        "--duration", "0.016", "--quiet"});
  INFO("exit " << r.code << ", stderr:\n" << r.err);
  REQUIRE(r.code == 0);
  CHECK_FALSE(contains(r.err, "done:"));  // --quiet: no progress line, no summary
  CHECK_FALSE(contains(r.err, "scene: "));
  const fs::path out = tmp.path / "out";
  CHECK(fs::exists(out / "particles.h5part"));
  CHECK_FALSE(fs::exists(out / "particles.h5part.partial"));
  CHECK(contains(readFile(out / "run.json"), "\"status\": \"complete\""));
}

TEST_CASE("cli: a quiet run that builds the kernels afresh writes nothing to stderr", "[cli]") {
  // pocl compiles the kernels on a device's first run and caches them (POCL_CACHE_DIR); its compiler's
  // warnings went to the user's stderr as a bare "2 warnings generated." (session 46: the list build's
  // 16-float loads on a CPU without AVX-512). An empty cache here makes this run compile them.
  TempDir tmp;
  const fs::path cache = tmp.path / "pocl-cache";
  fs::create_directories(cache);
  const char* old = std::getenv("POCL_CACHE_DIR");
  const std::string saved = old ? old : "";
  setenv("POCL_CACHE_DIR", cache.c_str(), 1);
  const Result r = sphaptics(tmp.path, {"run", kTinyScene.string(), "--out", "out", "--device", "cpu",
                                        "--duration", "0.016", "--quiet"});
  if (old) setenv("POCL_CACHE_DIR", saved.c_str(), 1);
  else unsetenv("POCL_CACHE_DIR");
  INFO("exit " << r.code << ", stderr:\n" << r.err);
  REQUIRE(r.code == 0);
  CHECK(r.err.empty());
  CHECK(r.out.empty());
}

TEST_CASE("cli: bench --accuracy-set and --accuracy-until reach the accuracy runs", "[cli]") {
  // The smallest accuracy run (1,000 particles) to T = 0.5 (t = 56.4 ms, 6.8 frames at 120 frames/s,
  // 3.4 at the scene's 60): the front series holds the start and one row per frame, 1 + 7 rows
  // (without the override, 1 + 3: measured).
  TempDir tmp;
  const Result r = sphaptics(tmp.path, {"bench", "--accuracy-only", "--no-impact", "--no-forces", "--no-iso",
                                        "--no-cloth", "--accuracy-sizes", "1000", "--accuracy-solvers", "dfsph",
                                        "--accuracy-cfl", "0.4", "--accuracy-until", "0.5", "--accuracy-set",
                                        "simulation.frame_rate=120", "--device", "cpu", "--out", "b"});
  INFO("exit " << r.code << ", stderr:\n" << r.err);
  REQUIRE(r.code == 0);
  const std::string series = readFile(tmp.path / "b" / "accuracy_front.csv");
  int frames = 0;
  for (std::size_t at = series.find(",frame,"); at != std::string::npos; at = series.find(",frame,", at + 1)) ++frames;
  CHECK(frames == 8);
  // both files say which overrides their runs took
  CHECK(contains(series, "# scene overrides of every run: simulation.frame_rate=120"));
  CHECK(contains(readFile(tmp.path / "b" / "accuracy.csv"), "# scene overrides of every run: simulation.frame_rate=120"));
}

TEST_CASE("cli: the bench's accuracy plot draws every solver, wall model and Courant number", "[cli]") {
  // scripts/plot_bench.py, as `bench` runs it on accuracy.csv. Until session 45 it drew only the
  // series wcsph / dfsph at Courant 0.4 and 0.2, and wrote an empty figure for anything else (a
  // Courant sweep, dfsph-extrapolated): the rows below are such a sweep (session 45's 50k figures)
  // and one WCSPH size series.
  TempDir tmp;
  const fs::path csv = tmp.path / "accuracy.csv", png = tmp.path / "accuracy.png";
  {
    std::ofstream out(csv);
    out << "# sphaptics accuracy benchmark (test rows)\n"
           "solver,particles,dx_m,cfl,steps,eos,mean_rel_error,max_rel_error,points,wall_s,particle_steps_per_s,"
           "wall_crossings,iterations_per_step\n"
           "dfsph-extrapolated,53312,0.00892857,0.4,303,-,0.018364,0.0525468,11,30.3569,532121,0,8.24752\n"
           "dfsph-extrapolated,53312,0.00892857,0.6,209,-,0.0182499,0.0545501,11,28.6662,388688,0,15.3971\n"
           "dfsph-extrapolated,53312,0.00892857,0.8,162,-,0.018903,0.0537637,11,28.5564,302438,0,21.8519\n"
           "wcsph,4000,0.02,0.25,900,linear,0.03,0.05,11,2.5,1e6,0,0\n"
           "wcsph,12000,0.014,0.25,1300,linear,0.025,0.045,11,9.5,1e6,0,0\n";
  }
  const fs::path log = tmp.path / "plot.log";
  const auto plot = [&](const fs::path& in) {
    const std::string cmd = "/usr/bin/python3 " + sph::testing::shellQuote((kSourceDir / "scripts/plot_bench.py").string()) +
                            " " + sph::testing::shellQuote(in.string()) + " " + sph::testing::shellQuote(png.string()) +
                            " >" + sph::testing::shellQuote(log.string()) + " 2>&1";
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  const int code = plot(csv);
  const std::string text = readFile(log);
  INFO("plot_bench.py:\n" << text);
  REQUIRE(code == 0);
  CHECK(contains(text, "series: DFSPH, extrapolated walls, Courant 0.4: 1 runs"));
  CHECK(contains(text, "series: DFSPH, extrapolated walls, Courant 0.6: 1 runs"));
  CHECK(contains(text, "series: DFSPH, extrapolated walls, Courant 0.8: 1 runs"));
  CHECK(contains(text, "series: WCSPH, linear EOS, Courant 0.25: 2 runs"));
  CHECK(contains(text, "plotted 5 runs in 4 series"));
  REQUIRE(fs::exists(png));
  CHECK(fs::file_size(png) > 10000);

  // a file with no run is an error, not an empty figure
  fs::remove(png);
  const fs::path empty = tmp.path / "empty.csv";
  std::ofstream(empty) << "solver,particles,dx_m,cfl,steps,eos,mean_rel_error,max_rel_error,points,wall_s\n";
  CHECK(plot(empty) == 1);
  CHECK(contains(readFile(log), "holds no accuracy run to plot"));
  CHECK_FALSE(fs::exists(png));
}
