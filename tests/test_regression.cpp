// Regression of the whole pipeline against committed output, and the Blender render of a run:
// - [regression]: scenes/tests/regression_surface.yaml, run now, against the golden OBJ sequence in
//   tests/data/golden/regression_surface/ (made only by scripts/make_golden.sh), with `compare`.
// - [blender]: two frames of the same scene rendered by scripts/render.sh are not blank; skipped
//   (with a warning) when `blender` is not on PATH.
#include "cli/compare.h"
#include "cli/runner.h"
#include "tests/run_binary.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace sph;
namespace fs = std::filesystem;

namespace {

const fs::path kSourceDir = SPHAPTICS_SOURCE_DIR;
const fs::path kScene = kSourceDir / "scenes/tests/regression_surface.yaml";
const fs::path kGolden = kSourceDir / "tests/data/golden/regression_surface";

/// The fluid_*.obj file names in a folder, sorted.
std::vector<std::string> objNames(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("fluid_", 0) == 0 && e.path().extension() == ".obj") names.push_back(n);
  }
  std::sort(names.begin(), names.end());
  return names;
}

/// `compare A B` with the default tolerances (1 dx Hausdorff, 0.25 dx mean offset, 5 % area);
/// the printed table goes to `text`.
int compareDefault(const fs::path& a, const fs::path& b, std::string& text) {
  app::CompareOptions o;
  o.a = a.string();
  o.b = b.string();
  std::ostringstream out, err;
  const int code = app::compareCommand(o, out, err);
  text = out.str() + err.str();
  return code;
}

app::RunResult runRegressionScene(const fs::path& out, double duration = -1.0) {
  app::RunOptions opt;
  opt.scene = kScene.string();
  opt.out = out.string();
  opt.duration = duration;
  opt.quiet = true;
  return app::runScene(opt);
}

/// Moves the highest vertex of an OBJ file up by `dz` (text edit: every other line is kept, so the
/// header with the particle spacing stays). Nothing lies above that vertex, so its distance to the
/// unmoved surface is exactly `dz`.
void raiseTopVertex(const fs::path& file, double dz) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  in.close();
  std::size_t top = lines.size();
  double top_z = -1e30;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].rfind("v ", 0) != 0) continue;
    double x, y, z;
    if (std::sscanf(lines[i].c_str(), "v %lf %lf %lf", &x, &y, &z) == 3 && z > top_z) {
      top_z = z;
      top = i;
    }
  }
  REQUIRE(top < lines.size());
  std::istringstream fields(lines[top].substr(2));
  std::vector<std::string> v;
  for (std::string f; fields >> f;) v.push_back(f);
  REQUIRE(v.size() >= 3);
  char z[64];
  std::snprintf(z, sizeof z, "%.9g", top_z + dz);
  v[2] = z;
  std::string line = "v";
  for (const auto& f : v) line += " " + f;
  lines[top] = line;
  std::ofstream outf(file, std::ios::trunc);
  for (const auto& l : lines) outf << l << "\n";
}

/// The "# particle_spacing: <dx> m" header value of an OBJ file, or 0.
double headerSpacing(const fs::path& file) {
  std::ifstream in(file);
  for (std::string l; std::getline(in, l) && !l.empty() && l[0] == '#';) {
    const auto k = l.find("particle_spacing:");
    if (k != std::string::npos) return std::atof(l.c_str() + k + 17);
  }
  return 0.0;
}

}  // namespace

// Tolerance. On this machine the run is deterministic (README "Physics and validation": same scene,
// same device, bitwise equal), so here the run equals the golden byte for byte and every distance is
// 0. The tolerances exist for other CPUs, pocl versions or OpenCL drivers, whose float rounding
// (fused multiply-add, reduction order inside a kernel, vector width) differs in the last bits.
// SPH is chaotic, so such differences grow over the steps, most of all where the flow splashes;
// the scene is therefore short (0.1 s, 5 frames, ending just after the drop meets the pool) so that
// last-bit differences stay well below a particle spacing. Measured as a stand-in: a rest density
// changed by 1e-6 (relative) moves the surface by at most 0.002 dx up to frame 4 and 0.16 dx at
// frame 5 (after the impact); the viscosity changed by 2e-6, 0.10 dx. The defaults (no surface
// point more than 1 dx, a whole particle layer, from the golden surface; mean surface offset,
// volume difference over area, under dx/4; area within 5 %) keep a margin of about 6 over that
// and still mean something physical. What fails (measured): the Wendland kernel in place of the
// cubic spline (2.7 dx), iso 0.6 in place of 0.5 (area 5.8 %), any change of the mesher's output.
// What does not: doubling the artificial viscosity (0.48 dx in 0.1 s). So this test guards the
// pipeline and large changes of physics or meshing, not small parameter changes (the physics tests
// do that). A change that should move the surface is a reason to regenerate, reviewed
// (scripts/make_golden.sh). Tighter tolerances would tie the test to one device's rounding.
TEST_CASE("regression: the surface of regression_surface.yaml matches the golden OBJ sequence", "[regression]") {
  REQUIRE(fs::is_directory(kGolden));
  const std::vector<std::string> golden = objNames(kGolden);
  REQUIRE(!golden.empty());

  testing::TempDir tmp;
  const fs::path run_dir = tmp.path / "run";
  const app::RunResult run = runRegressionScene(run_dir);
  INFO(run.message);
  REQUIRE(run.exit_code == 0);

  // Same frames: the frame count (and the phase names) of the run equal the golden's.
  const std::vector<std::string> produced = objNames(run_dir);
  CHECK(produced == golden);
  CHECK(produced.size() == 2u * static_cast<std::size_t>(run.frames + 1));  // two phases, frames 0..N

  std::string table;
  const int code = compareDefault(kGolden, run_dir, table);
  INFO("sphaptics compare " << kGolden.string() << " RUN:\n" << table);
  CHECK(code == 0);
  CHECK(table.find("FAIL") == std::string::npos);
}

TEST_CASE("regression: compare rejects perturbed copies of the golden sequence", "[regression]") {
  const std::vector<std::string> golden = objNames(kGolden);
  REQUIRE(golden.size() >= 4);
  testing::TempDir tmp;
  std::string table;

  // The golden against itself: exit 0.
  REQUIRE(compareDefault(kGolden, kGolden, table) == 0);

  // One vertex of the last frame moved 2 dx (twice the Hausdorff tolerance): exit 1, that frame named.
  {
    const fs::path copy = tmp.path / "moved";
    fs::create_directories(copy);
    for (const auto& n : golden) fs::copy_file(kGolden / n, copy / n);
    const std::string last = golden.back();
    const double dx = headerSpacing(copy / last);
    REQUIRE(dx > 0);
    raiseTopVertex(copy / last, 2.0 * dx);
    const int code = compareDefault(kGolden, copy, table);
    INFO(table);
    CHECK(code == 1);
    CHECK(table.find(last) != std::string::npos);
  }

  // A later frame in place of an earlier one (the last frame's file renamed to frame 1, of the
  // same phase): the surface moved on in between, exit 1.
  {
    const fs::path copy = tmp.path / "shuffled";
    fs::create_directories(copy);
    for (const auto& n : golden) fs::copy_file(kGolden / n, copy / n);
    // Pick a phase's last file and put it over that phase's frame 0001.
    const std::string last = golden.back();                        // fluid_<phase>_NNNN.obj
    const std::string phase_prefix = last.substr(0, last.size() - 8);  // fluid_<phase>_
    fs::remove(copy / (phase_prefix + "0001.obj"));
    fs::rename(copy / last, copy / (phase_prefix + "0001.obj"));
    fs::copy_file(kGolden / last, copy / last);
    const int code = compareDefault(kGolden, copy, table);
    INFO(table);
    CHECK(code == 1);
    CHECK(table.find(phase_prefix + "0001.obj") != std::string::npos);
  }

  // A frame missing: exit 1 (frame sets differ).
  {
    const fs::path copy = tmp.path / "short";
    fs::create_directories(copy);
    for (const auto& n : golden) fs::copy_file(kGolden / n, copy / n);
    fs::remove(copy / golden.back());
    CHECK(compareDefault(kGolden, copy, table) == 1);
  }
}

// Blender is optional (Debian's package is about 570 MB; CI may not install it): without it the
// test passes with a warning. With it: two frames of the regression scene rendered at 160x120 with
// 4 samples (Cycles, CPU) must give two PNGs whose pixels vary (a blank, black or single-colour
// image has std 0 and one distinct colour). scripts/png_stats.py decodes them with the standard
// library (zlib) only.
TEST_CASE("blender: render.sh renders two non-blank frames of a tiny run", "[blender]") {
  if (std::system("command -v blender >/dev/null 2>&1") != 0) {
    WARN("blender is not on PATH: render test skipped (apt-get install --no-install-recommends blender)");
    return;
  }
  testing::TempDir tmp;
  const fs::path run_dir = tmp.path / "run";
  // One frame of simulation (0.02 s): output frames 0 and 1.
  const app::RunResult run = runRegressionScene(run_dir, 0.02);
  INFO(run.message);
  REQUIRE(run.exit_code == 0);
  REQUIRE(fs::exists(run_dir / "fluid_water_0001.obj"));

  const fs::path log = tmp.path / "render.log";
  const std::string cmd = testing::shellQuote((kSourceDir / "scripts/render.sh").string()) + " " +
                          testing::shellQuote(run_dir.string()) +
                          " --frames 0:1 --resolution 160x120 --samples 4 >" + testing::shellQuote(log.string()) +
                          " 2>&1 </dev/null";
  const int status = std::system(cmd.c_str());
  INFO("render.sh log:\n" << testing::readFile(log));
  REQUIRE(status == 0);

  const fs::path png0 = run_dir / "render/frame_0000.png", png1 = run_dir / "render/frame_0001.png";
  REQUIRE(fs::exists(png0));
  REQUIRE(fs::exists(png1));

  const fs::path stats = tmp.path / "stats.txt";
  const std::string stats_cmd = "/usr/bin/env python3 " + testing::shellQuote((kSourceDir / "scripts/png_stats.py").string()) +
                                " " + testing::shellQuote(png0.string()) + " " + testing::shellQuote(png1.string()) + " >" +
                                testing::shellQuote(stats.string()) + " 2>&1";
  const int stats_status = std::system(stats_cmd.c_str());
  const std::string text = testing::readFile(stats);
  INFO("png_stats.py:\n" << text);
  REQUIRE(stats_status == 0);

  std::istringstream lines(text);
  int images = 0;
  for (std::string line; std::getline(lines, line);) {
    std::map<std::string, double> v;
    std::istringstream fields(line);
    for (std::string f; fields >> f;) {
      const auto eq = f.find('=');
      if (eq != std::string::npos) v[f.substr(0, eq)] = std::atof(f.c_str() + eq + 1);
    }
    INFO(line);
    CHECK(v["width"] == 160);
    CHECK(v["height"] == 120);
    // Not blank: the colours spread over a real range (fluid, floor, background), many of them.
    CHECK(v["max"] - v["min"] > 30);
    CHECK(v["std"] > 5);
    CHECK(v["distinct"] > 50);
    ++images;
  }
  CHECK(images == 2);
}
