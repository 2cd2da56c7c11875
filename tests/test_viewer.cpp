// The viewer (issue 13): reading an output folder back (H5Part, run.json, OBJ sequences, PNG), the
// `view` command's input checks, and screenshots under Xvfb with Mesa's software OpenGL whose
// pixels must show the water and the body where the run put them.
#include "cli/runner.h"
#include "core/errors.h"
#include "io/h5part_reader.h"
#include "io/h5part_writer.h"
#include "io/png.h"
#include "io/run_folder.h"
#include "tests/run_binary.h"
#include "tests/simulate_into.h"
#include "tests/soft_run.h"
#include "tests/temp_dir.h"
#include "viewer/camera.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

using namespace sph;
namespace fs = std::filesystem;

namespace {

const fs::path kSourceDir = SPHAPTICS_SOURCE_DIR;

/// Screenshot size for the tests: small, so that the software rasteriser is quick (unit: pixels).
constexpr int kWidth = 480, kHeight = 270;

/// Why the screenshot tests cannot run here, or "" when they can.
std::string screenshotSkipReason() {
  if (!SPHAPTICS_HAVE_VIEWER) return "this build has no viewer (GLFW, OpenGL or Dear ImGui missing at configure time)";
  if (std::system("command -v xvfb-run >/dev/null 2>&1") != 0) return "xvfb-run is not installed (apt-get install xvfb xauth)";
  return "";
}

/// `sphaptics view DIR --screenshot PNG args...` under Xvfb with Mesa's software OpenGL.
void screenshot(const fs::path& dir, const fs::path& png, const std::vector<std::string>& args) {
  std::string cmd = "LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a " + testing::shellQuote(SPHAPTICS_BINARY) + " view " +
                    testing::shellQuote(dir.string()) + " --screenshot " + testing::shellQuote(png.string()) +
                    " --width " + std::to_string(kWidth) + " --height " + std::to_string(kHeight);
  for (const auto& a : args) cmd += " " + testing::shellQuote(a);
  const fs::path log = dir / "view.log";
  cmd += " >" + testing::shellQuote(log.string()) + " 2>&1 </dev/null";
  const int status = std::system(cmd.c_str());
  INFO(cmd << "\n" << testing::readFile(log));
  REQUIRE(status == 0);
  REQUIRE(fs::exists(png));
}

/// Pixel (x right, y down) of a world point seen by the viewer's default camera, which frames
/// the domain box (viewer/camera.h; the screenshot uses it unchanged).
Eigen::Vector2f project(const viewer::OrbitCamera& cam, const Eigen::Vector3f& p) {
  const Eigen::Vector4f clip = cam.projection(static_cast<float>(kWidth) / kHeight) * cam.view() * p.homogeneous();
  return {(clip.x() / clip.w() + 1) * 0.5f * kWidth, (1 - clip.y() / clip.w()) * 0.5f * kHeight};
}

/// Screen rectangle (x0, y0, x1, y1) of a world box's eight projected corners.
Eigen::Vector4f screenRect(const viewer::OrbitCamera& cam, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  Eigen::Vector4f r(1e9f, 1e9f, -1e9f, -1e9f);
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector2f q = project(cam, {i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z()});
    r = {std::min(r[0], q.x()), std::min(r[1], q.y()), std::max(r[2], q.x()), std::max(r[3], q.y())};
  }
  return r;
}

/// Pixels of one hue: the water's blue (phase colour 0.2, 0.4, 0.9) or the ball's red, under any
/// shading; the background, the box and the floor are grey (R = G = B) and never match.
bool isWater(const uint8_t* c) { return c[2] > c[0] + 40 && c[2] > c[1] + 20; }
bool isRed(const uint8_t* c) { return c[0] > c[1] + 80 && c[0] > c[2] + 80; }

struct Pixels {
  std::vector<Eigen::Vector2f> at;  ///< pixel centres
  float x_max = -1, y_min = 1e9f;   ///< rightmost column, highest row
  Eigen::Vector2f centroid() const {
    Eigen::Vector2f c = Eigen::Vector2f::Zero();
    for (const auto& p : at) c += p;
    return at.empty() ? c : Eigen::Vector2f(c / static_cast<float>(at.size()));
  }
  std::size_t inside(const Eigen::Vector4f& r, float margin) const {
    return static_cast<std::size_t>(std::count_if(at.begin(), at.end(), [&](const Eigen::Vector2f& p) {
      return p.x() >= r[0] - margin && p.x() <= r[2] + margin && p.y() >= r[1] - margin && p.y() <= r[3] + margin;
    }));
  }
};

template <typename Pred>
Pixels pixelsOf(const io::RgbImage& img, Pred pred) {
  Pixels px;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      if (pred(img.at(x, y))) {
        px.at.emplace_back(x + 0.5f, y + 0.5f);
        px.x_max = std::max(px.x_max, x + 0.5f);
        px.y_min = std::min(px.y_min, y + 0.5f);
      }
  return px;
}

using sph::testing::simulate;

ParticleFrame smallFrame(double time, int n) {
  ParticleFrame f;
  f.time = time;
  for (int i = 0; i < n; ++i) {
    const float v = 0.25f * static_cast<float>(i) + static_cast<float>(time);
    f.x.push_back(v);
    f.y.push_back(-v);
    f.z.push_back(2 * v);
    f.vx.push_back(1 + v);
    f.vy.push_back(2 + v);
    f.vz.push_back(3 + v);
    f.density.push_back(1000 + v);
    f.pressure.push_back(100 * v);
    f.phase.push_back(i % 2);
    f.id.push_back(1000000000000LL + i);
    f.r.push_back(0.1f);
    f.g.push_back(0.2f);
    f.b.push_back(0.3f);
  }
  return f;
}

}  // namespace

TEST_CASE("viewer io: PNG round trip, and files that are not PNGs are refused", "[viewer]") {
  testing::TempDir tmp;
  io::RgbImage img;
  img.width = 37;  // odd width: rows are not 4-byte aligned
  img.height = 11;
  for (int i = 0; i < img.width * img.height * 3; ++i) img.rgb.push_back(static_cast<uint8_t>((i * 7919) % 251));
  const fs::path png = tmp.path / "a.png";
  io::writePng(png.string(), img);
  const io::RgbImage back = io::readPng(png.string());
  CHECK(back.width == 37);
  CHECK(back.height == 11);
  CHECK(back.rgb == img.rgb);
  CHECK_THROWS_WITH(io::readPng(tmp.write("b.png", "not a png").string()), Catch::Contains("not a PNG"));
  CHECK_THROWS_WITH(io::readPng((tmp.path / "missing.png").string()), Catch::Contains("missing.png"));
}

TEST_CASE("viewer io: H5PartReader reads back every field the writer wrote", "[viewer]") {
  testing::TempDir tmp;
  const fs::path file = tmp.path / "particles.h5part.partial";
  const ParticleFrame a = smallFrame(0.0, 5), b = smallFrame(0.04, 3);
  {
    io::H5PartWriter w(file.string());
    w.writeStep(a);
    w.writeStep(b);
  }
  CHECK(io::particlesFile(tmp.path.string()) == file.string());
  io::H5PartReader r(file.string());
  REQUIRE(r.steps() == 2);
  const ParticleFrame c = r.readStep(1);
  CHECK(c.time == b.time);
  CHECK(c.x == b.x);
  CHECK(c.y == b.y);
  CHECK(c.z == b.z);
  CHECK(c.vx == b.vx);
  CHECK(c.vy == b.vy);
  CHECK(c.vz == b.vz);
  CHECK(c.density == b.density);
  CHECK(c.pressure == b.pressure);
  CHECK(c.phase == b.phase);
  CHECK(c.id == b.id);
  CHECK(c.r == b.r);
  CHECK(c.g == b.g);
  CHECK(c.b == b.b);
  CHECK(r.readStep(0).size() == 5);
  CHECK_THROWS_WITH(r.readStep(2), Catch::Contains("Step#2"));
}

TEST_CASE("viewer io: run.json's domain and colours, OBJ sequences, bad JSON located", "[viewer]") {
  testing::TempDir tmp;
  tmp.write("run.json", R"({"status": "running", "scene": {"domain": {"min": [0, -1, 0], "max": [2, 1, 0.5]},
    "simulation": {"frame_rate": 25}, "fluid": {"particle_spacing": 0.02, "phases": [{"name": "oil", "colour": [0.9, 0.8, 0.1]}]},
    "rigid_bodies": [{"name": "ball", "colour": [1, 0, 0]}]}})");
  for (const char* name : {"fluid_oil_0000.obj", "fluid_oil_0002.obj", "body_ball_0001.obj", "body_ball_x.obj", "notes.obj"})
    tmp.write(name, "v 0 0 0\n");
  const io::RunFolderInfo info = io::readRunFolderInfo(tmp.path.string());
  CHECK(info.status == "running");
  CHECK(info.has_domain);
  CHECK(info.domain_min == Eigen::Vector3f(0, -1, 0));
  CHECK(info.domain_max == Eigen::Vector3f(2, 1, 0.5f));
  CHECK(info.particle_spacing == Approx(0.02));
  CHECK(info.frame_rate == Approx(25));
  REQUIRE(info.phases.size() == 1);
  CHECK(info.phases[0].first == "oil");
  CHECK(info.phases[0].second.x() == Approx(0.9f));
  REQUIRE(info.bodies.size() == 1);
  CHECK(info.bodies[0].second == Eigen::Vector3f(1, 0, 0));

  const auto seqs = io::scanObjSequences(tmp.path.string());
  REQUIRE(seqs.size() == 2);
  CHECK(seqs[0].name == "body_ball");
  CHECK(seqs[0].body);
  CHECK(seqs[0].frames.count(1) == 1);
  CHECK(seqs[1].name == "fluid_oil");
  CHECK(seqs[1].frames.size() == 2);
  CHECK(seqs[1].frames.count(2) == 1);

  tmp.write("run.json", "{\"status\": \"complete\",\n  \"frames\": [1, 2\n}\n");
  CHECK_THROWS_WITH(io::readRunFolderInfo(tmp.path.string()), Catch::Contains("run.json:3:"));
}

// Soft bodies (soft_<name>_NNNN.obj, written by the soft-body exporter in the cloth OBJ's format):
// listed as their own kind in the bodies layer, with their colour from run.json's soft_bodies.
TEST_CASE("viewer io: soft-body surface sequences soft_<name>_NNNN.obj and their colours", "[viewer]") {
  testing::TempDir tmp;
  testing::writeSoftRun(tmp);
  tmp.write("cloth_sheet_0000.obj", "v 0 0 0\n");
  const io::RunFolderInfo info = io::readRunFolderInfo(tmp.path.string());
  REQUIRE(info.soft_bodies.size() == 1);
  CHECK(info.soft_bodies[0].first == "jelly");
  CHECK(info.soft_bodies[0].second == Eigen::Vector3f(0.1f, 0.8f, 0.2f));
  const auto seqs = io::scanObjSequences(tmp.path.string());
  REQUIRE(seqs.size() == 2);
  CHECK(seqs[0].name == "cloth_sheet");
  CHECK((seqs[0].cloth && !seqs[0].soft));
  CHECK(seqs[1].name == "soft_jelly");
  CHECK((seqs[1].soft && seqs[1].body && !seqs[1].cloth));
  CHECK(seqs[1].frames.size() == static_cast<std::size_t>(testing::kSoftFrames));
}

TEST_CASE("viewer: bad folder, frame or option give a message and exit code 2", "[viewer][cli]") {
  if (!SPHAPTICS_HAVE_VIEWER) {
    WARN("SKIPPED: this build has no viewer (GLFW, OpenGL or Dear ImGui missing at configure time)");
    return;
  }
  testing::TempDir tmp;
  {
    io::H5PartWriter w((tmp.path / "particles.h5part").string());
    w.writeStep(smallFrame(0.0, 4));
    w.writeStep(smallFrame(0.1, 4));
  }
  // The folder is checked before any window is opened: no display is needed.
  auto r = testing::sphaptics(tmp.path, {"view", "no_such_run"});
  CHECK(r.code == 2);
  CHECK(r.err.find("no_such_run: no such output folder") != std::string::npos);
  r = testing::sphaptics(tmp.path, {"view", ".", "--frame", "7", "--screenshot", "x.png"});
  CHECK(r.code == 2);
  CHECK(r.err.find("frame 7 is not in the run (frames 0 to 1)") != std::string::npos);
  r = testing::sphaptics(tmp.path, {"view", ".", "--frame", "two"});
  CHECK(r.code == 2);
  CHECK(r.err.find("'two' is not a frame index or 'last'") != std::string::npos);
  r = testing::sphaptics(tmp.path, {"view", ".", "--colour", "vorticity"});
  CHECK(r.code == 2);
  CHECK(r.err.find("vorticity") != std::string::npos);
  fs::create_directories(tmp.path / "empty");
  r = testing::sphaptics(tmp.path, {"view", "empty"});
  CHECK(r.code == 2);
  CHECK(r.err.find("nothing to show") != std::string::npos);
  CHECK_FALSE(fs::exists(tmp.path / "x.png"));
}

// Dam break (Martin & Moyce 1952, column a = 0.1 m wide, 2a high) at a coarse 1 cm spacing, 0.25 s
// (T = t sqrt(2g/a) = 3.5). Frame 0: every water pixel inside the projected column, which it fills.
// Last frame: the front has passed x = 0.25 m (Z = x/a = 2.5; the experiment gives Z ~ 4 at T = 3.5,
// and a coarse slab runs up to 17 % slower, README "Physics") and the water is lower than 0.15 m
// (the experiment's residual column at T = 3.5 is under 0.4 x 2a = 0.08 m).
TEST_CASE("viewer: dam-break screenshots show the water left and low, then spread along the floor", "[viewer][xvfb]") {
  if (const std::string why = screenshotSkipReason(); !why.empty()) {
    WARN("SKIPPED: " << why);
    return;
  }
  testing::TempDir tmp;
  const fs::path run = tmp.path / "run";
  simulate(kSourceDir / "scenes/tests/dam_break_slab.yaml", run, 0.25, {"fluid.particle_spacing=0.01"});
  screenshot(run, tmp.path / "first.png", {"--frame", "0"});
  screenshot(run, tmp.path / "last.png", {"--frame", "last"});
  const io::RgbImage first = io::readPng((tmp.path / "first.png").string());
  const io::RgbImage last = io::readPng((tmp.path / "last.png").string());
  REQUIRE(first.width == kWidth);
  REQUIRE(first.height == kHeight);

  // The camera the viewer uses: the default orbit camera framing the domain box.
  viewer::OrbitCamera cam;
  cam.frame({0, 0, 0}, {0.5f, 0.04f, 0.3f}, static_cast<float>(kWidth) / kHeight);
  const float r = 0.005f;  // sprite radius: half the spacing (unit: m)
  const Eigen::Vector4f column = screenRect(cam, {-r, -r, -r}, {0.1f + r, 0.04f + r, 0.2f + r});
  const float column_area = (column[2] - column[0]) * (column[3] - column[1]);

  // Frame 0: the column, left and low, and nothing else blue.
  const Pixels w0 = pixelsOf(first, isWater);
  INFO("frame 0: " << w0.at.size() << " water pixels, column rectangle " << column.transpose() << " (" << column_area << " px^2)");
  CHECK(w0.at.size() > 0.5 * column_area);
  CHECK(w0.inside(column, 1.0f) == w0.at.size());
  CHECK(w0.centroid().x() < kWidth / 2.0f);

  // Last frame: spread to the right along the floor, and lower.
  const Pixels w1 = pixelsOf(last, isWater);
  const float x_quarter = project(cam, {0.25f, 0.0f, 0.0f}).x();  // the domain's centre column
  float z15_top = 1e9f;  // highest pixel of the plane z = 0.15 m over the domain's floor corners
  for (float x : {0.0f, 0.5f})
    for (float y : {0.0f, 0.04f}) z15_top = std::min(z15_top, project(cam, {x, y, 0.15f}).y());
  INFO("last frame: " << w1.at.size() << " water pixels, front at pixel " << w1.x_max << " (x = 0.25 m at " << x_quarter
                      << "), top at row " << w1.y_min << " (z = 0.15 m at row " << z15_top << " or below)");
  CHECK(w1.at.size() > 0.3 * column_area);
  CHECK(w1.x_max > x_quarter);
  CHECK(w1.y_min > z15_top);
  // The same checks on frame 0 fail: they tell the two states apart.
  CHECK(w0.x_max < x_quarter);
  CHECK(w0.y_min < z15_top);
}

// A red ball over a pool with the surface meshed (particles, fluid_water_*.obj, body_ball_*.obj):
// the red pixels are the ball, centred where bodies.csv says it is, at the first and last frame.
TEST_CASE("viewer: screenshots of a run with a body show it in its colour where it is", "[viewer][xvfb]") {
  if (const std::string why = screenshotSkipReason(); !why.empty()) {
    WARN("SKIPPED: " << why);
    return;
  }
  testing::TempDir tmp;
  const fs::path run = tmp.path / "run";
  simulate(kSourceDir / "scenes/tests/view_ball.yaml", run, -1, {});
  REQUIRE(fs::exists(run / "body_ball_0000.obj"));
  REQUIRE(fs::exists(run / "fluid_water_0000.obj"));
  screenshot(run, tmp.path / "first.png", {"--frame", "0"});
  screenshot(run, tmp.path / "last.png", {"--frame", "last", "--hide", "particles"});

  // Ball centres per frame from bodies.csv (time, body, com_x, com_y, com_z, ...).
  std::vector<Eigen::Vector3f> centres;
  {
    std::istringstream lines(testing::readFile(run / "bodies.csv"));
    for (std::string line; std::getline(lines, line);) {
      if (line.empty() || line[0] == '#' || line.rfind("time", 0) == 0) continue;
      std::istringstream cells(line);
      std::string cell;
      std::vector<std::string> v;
      while (std::getline(cells, cell, ',')) v.push_back(cell);
      REQUIRE(v.size() >= 5);
      centres.emplace_back(std::stof(v[2]), std::stof(v[3]), std::stof(v[4]));
    }
  }
  REQUIRE(centres.size() == 3);  // frames 0, 1, 2

  viewer::OrbitCamera cam;
  cam.frame({0, 0, 0}, {0.2f, 0.1f, 0.2f}, static_cast<float>(kWidth) / kHeight);
  const float radius = 0.03f;  // (unit: m)
  const std::pair<const char*, const Eigen::Vector3f*> frames[] = {{"first.png", &centres.front()}, {"last.png", &centres.back()}};
  for (const auto& [name, centre] : frames) {
    const io::RgbImage img = io::readPng((tmp.path / name).string());
    const Pixels red = pixelsOf(img, isRed);
    const Eigen::Vector2f c = project(cam, *centre);
    const float r_px = std::abs(project(cam, *centre + Eigen::Vector3f(0, 0, radius)).y() - c.y());
    INFO(name << ": " << red.at.size() << " red pixels, centroid " << red.centroid().transpose() << ", ball centre at "
              << c.transpose() << ", radius " << r_px << " px");
    // The disc of the ball, within a pixel or two (a sphere's perspective image is nearly a disc).
    CHECK(red.at.size() > 0.8 * 3.14159 * r_px * r_px);
    CHECK(red.at.size() < 1.2 * 3.14159 * r_px * r_px);
    CHECK((red.centroid() - c).norm() < 2.0f);
    // The pool (surface mesh, and particles in the first) is there too, below the ball.
    const Pixels water = pixelsOf(img, isWater);
    CHECK(water.at.size() > 0);
    CHECK(water.centroid().y() > c.y());
  }
}

// A hand-made folder with only a soft body's OBJ sequence (a green cube moving along x; no
// particles): `view` plays it, and the last frame shows the cube's green inside its projected
// box, filling more than half of it (a cube's silhouette is a hexagon inside that rectangle),
// centred within 3 px of the projected centre.
TEST_CASE("viewer: a soft body's surface sequence is drawn in its colour where it is", "[viewer][xvfb]") {
  if (const std::string why = screenshotSkipReason(); !why.empty()) {
    WARN("SKIPPED: " << why);
    return;
  }
  testing::TempDir tmp;
  testing::writeSoftRun(tmp);
  screenshot(tmp.path, tmp.path / "last.png", {"--frame", "last"});
  const io::RgbImage img = io::readPng((tmp.path / "last.png").string());
  viewer::OrbitCamera cam;
  cam.frame({0, 0, 0}, {0.2f, 0.1f, 0.2f}, static_cast<float>(kWidth) / kHeight);
  const Eigen::Vector3f c = testing::softCentre(testing::kSoftFrames - 1);
  const Eigen::Vector3f half = Eigen::Vector3f::Constant(0.5f * testing::kSoftSide);
  const Eigen::Vector4f box = screenRect(cam, c - half, c + half);
  const float area = (box[2] - box[0]) * (box[3] - box[1]);
  const Pixels green = pixelsOf(img, testing::isSoftGreen);
  INFO(green.at.size() << " green pixels, centroid " << green.centroid().transpose() << "; cube at " << project(cam, c).transpose()
                       << ", rectangle " << box.transpose() << " (" << area << " px^2)");
  CHECK(green.at.size() > 0.5 * area);
  CHECK(green.inside(box, 1.0f) == green.at.size());
  CHECK((green.centroid() - project(cam, c)).norm() < 3.0f);
}
