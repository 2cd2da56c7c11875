// Blender renders of run folders (scripts/render.sh, issue 13): the water and the bodies appear in
// the picture where the run put them. render_blender.py writes its camera as a world -> clip
// matrix (render/camera.json), so the test projects the run's geometry itself and looks at the
// pixels there. Blender is optional (Debian's package is about 570 MB and CI does not install it):
// without `blender` on PATH the tests say SKIPPED and why.
#include "cli/runner.h"
#include "io/png.h"
#include "tests/run_binary.h"
#include "tests/simulate_into.h"
#include "tests/soft_run.h"
#include "tests/temp_dir.h"

#include <catch2/catch.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace sph;
namespace fs = std::filesystem;

namespace {

const fs::path kSourceDir = SPHAPTICS_SOURCE_DIR;

/// Why the render tests cannot run here, or "" when they can.
std::string renderSkipReason() {
  if (std::system("command -v blender >/dev/null 2>&1") != 0)
    return "blender is not on PATH (apt-get install --no-install-recommends blender; CI does not install it)";
  return "";
}

using sph::testing::simulate;

/// scripts/render.sh RUN --frames A:B at W x H with few samples; returns the log.
void render(const fs::path& run, const std::string& frames, int width, int height) {
  const fs::path log = run / "render.log";
  const std::string cmd = testing::shellQuote((kSourceDir / "scripts/render.sh").string()) + " " +
                          testing::shellQuote(run.string()) + " --frames " + frames + " --resolution " +
                          std::to_string(width) + "x" + std::to_string(height) + " --samples 8 >" +
                          testing::shellQuote(log.string()) + " 2>&1 </dev/null";
  const int status = std::system(cmd.c_str());
  INFO("render.sh log:\n" << testing::readFile(log));
  REQUIRE(status == 0);
}

/// The render's camera from RUN/render/camera.json: world -> pixel (x right, y down).
struct RenderCamera {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();  ///< world -> clip
  int width = 0, height = 0;                        ///< (unit: pixels)
  Eigen::Vector2d project(const Eigen::Vector3d& p) const {
    const Eigen::Vector4d c = m * p.homogeneous();
    return {(c.x() / c.w() + 1) * 0.5 * width, (1 - c.y() / c.w()) * 0.5 * height};
  }
  /// Screen rectangle (x0, y0, x1, y1) of a world box's eight projected corners.
  Eigen::Vector4d rect(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const {
    Eigen::Vector4d r(1e9, 1e9, -1e9, -1e9);
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector2d q = project({i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z()});
      r = {std::min(r[0], q.x()), std::min(r[1], q.y()), std::max(r[2], q.x()), std::max(r[3], q.y())};
    }
    return r;
  }
};

/// Reads camera.json: {"resolution": [W, H], "world_to_clip": [[4 numbers] x 4]} (the numbers in
/// order after each key; the file is written by render_blender.py only).
RenderCamera readCamera(const fs::path& file) {
  const std::string text = testing::readFile(file);
  auto numbersAfter = [&](const std::string& key, int n) {
    std::vector<double> v;
    std::size_t pos = text.find("\"" + key + "\"");
    REQUIRE(pos != std::string::npos);
    pos = text.find(':', pos) + 1;
    while (static_cast<int>(v.size()) < n && pos < text.size()) {
      const char c = text[pos];
      if (c == '-' || c == '+' || c == '.' || (c >= '0' && c <= '9')) {
        char* end = nullptr;
        v.push_back(std::strtod(text.c_str() + pos, &end));
        pos = static_cast<std::size_t>(end - text.c_str());
      } else {
        ++pos;
      }
    }
    REQUIRE(static_cast<int>(v.size()) == n);
    return v;
  };
  RenderCamera cam;
  const std::vector<double> res = numbersAfter("resolution", 2), m = numbersAfter("world_to_clip", 16);
  cam.width = static_cast<int>(res[0]);
  cam.height = static_cast<int>(res[1]);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) cam.m(r, c) = m[static_cast<std::size_t>(4 * r + c)];
  return cam;
}

/// Pixel centres of one hue. Background, floor and the domain are grey (R ~ G ~ B within 10);
/// the water is clear glass tinted with its phase's blue (0.2, 0.4, 0.9), blue above red by more
/// than 25 under Cycles' shading; the red ball's red is above both others by more than 80.
bool isWater(const uint8_t* c) { return c[2] > c[0] + 25 && c[2] > c[1] + 10; }
bool isRed(const uint8_t* c) { return c[0] > c[1] + 80 && c[0] > c[2] + 80; }

template <typename Pred>
std::vector<Eigen::Vector2d> pixelsOf(const io::RgbImage& img, Pred pred) {
  std::vector<Eigen::Vector2d> out;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      if (pred(img.at(x, y))) out.emplace_back(x + 0.5, y + 0.5);
  return out;
}

std::size_t inside(const std::vector<Eigen::Vector2d>& px, const Eigen::Vector4d& r, double margin) {
  return static_cast<std::size_t>(std::count_if(px.begin(), px.end(), [&](const Eigen::Vector2d& p) {
    return p.x() >= r[0] - margin && p.x() <= r[2] + margin && p.y() >= r[1] - margin && p.y() <= r[3] + margin;
  }));
}

/// Not blank: the pixel values spread over a real range, in many distinct colours.
void checkNotBlank(const io::RgbImage& img) {
  int lo = 255, hi = 0;
  std::vector<uint32_t> colours;
  for (std::size_t i = 0; i + 2 < img.rgb.size(); i += 3) {
    lo = std::min({lo, int{img.rgb[i]}, int{img.rgb[i + 1]}, int{img.rgb[i + 2]}});
    hi = std::max({hi, int{img.rgb[i]}, int{img.rgb[i + 1]}, int{img.rgb[i + 2]}});
    colours.push_back(uint32_t{img.rgb[i]} << 16 | uint32_t{img.rgb[i + 1]} << 8 | img.rgb[i + 2]);
  }
  std::sort(colours.begin(), colours.end());
  const auto distinct = std::unique(colours.begin(), colours.end()) - colours.begin();
  INFO("pixel range " << lo << ".." << hi << ", " << distinct << " distinct colours");
  CHECK(hi - lo > 30);
  CHECK(distinct > 50);
}

}  // namespace

// The coarse dam break (dam_break_slab.yaml at dx = 1 cm) at t = 0, surface meshed, rendered at
// 200 x 120: the water is the column 0.1 m wide and 0.2 m high at the left wall. Every water-blue
// pixel lies inside the column's projected rectangle (the surface closes half a spacing outside
// the particles: the box grows by dx/2 and a pixel of margin), and the water fills more than half
// of that rectangle (the column's silhouette is a hexagon inside it: measured 68 %).
TEST_CASE("render.sh: a Blender render of a dam break shows the water as the column at the left wall", "[blender][render]") {
  if (const std::string why = renderSkipReason(); !why.empty()) {
    WARN("SKIPPED: " << why);
    return;
  }
  testing::TempDir tmp;
  const fs::path run = tmp.path / "run";
  simulate(kSourceDir / "scenes/tests/dam_break_slab.yaml", run, 0.01,
           {"fluid.particle_spacing=0.01", "output.isosurface.enabled=true"});
  REQUIRE(fs::exists(run / "fluid_water_0000.obj"));
  render(run, "0:0", 200, 120);
  const io::RgbImage img = io::readPng((run / "render/frame_0000.png").string());
  const RenderCamera cam = readCamera(run / "render/camera.json");
  REQUIRE(img.width == 200);
  REQUIRE(cam.width == 200);
  REQUIRE(cam.height == img.height);
  checkNotBlank(img);

  const double h = 0.005;  // half the spacing (unit: m)
  const Eigen::Vector4d column = cam.rect({-h, -h, -h}, {0.1 + h, 0.04 + h, 0.2 + h});
  const double area = (column[2] - column[0]) * (column[3] - column[1]);
  const std::vector<Eigen::Vector2d> water = pixelsOf(img, isWater);
  const std::size_t in = inside(water, column, 1.0);
  INFO(water.size() << " water pixels, " << in << " inside the column's rectangle " << column.transpose() << " ("
                    << area << " px^2)");
  CHECK(water.size() > 0.5 * area);
  CHECK(in == water.size());
  // The rest of the tank (x > 0.15 m) is empty: its projection holds no water.
  const Eigen::Vector4d right = cam.rect({0.15, 0, 0}, {0.5, 0.04, 0.2});
  CHECK(inside(water, right, 0.0) == 0);
}

// A red ball 6 cm above a pool (view_ball.yaml: body_ball_*.obj with vertex colours and the pool's
// fluid_water_*.obj), last frame: the red pixels are the ball, their centroid within 2 px of the
// projection of the centre bodies.csv gives, and they fill 75-125 % of its projected disc (radius R
// about 11 px, the projected distance to the sphere's side: a one-pixel ring of anti-aliased edge
// counted in or out is 2/R, about 18 %; measured 106 %). The pool's water lies below the ball, low in the picture.
TEST_CASE("render.sh: a Blender render shows a body in its vertex colour where bodies.csv puts it", "[blender][render]") {
  if (const std::string why = renderSkipReason(); !why.empty()) {
    WARN("SKIPPED: " << why);
    return;
  }
  testing::TempDir tmp;
  const fs::path run = tmp.path / "run";
  simulate(kSourceDir / "scenes/tests/view_ball.yaml", run, -1, {});
  REQUIRE(fs::exists(run / "body_ball_0002.obj"));
  render(run, "2:2", 200, 150);
  const io::RgbImage img = io::readPng((run / "render/frame_0002.png").string());
  const RenderCamera cam = readCamera(run / "render/camera.json");
  checkNotBlank(img);

  // The ball's centre at the last frame (bodies.csv: time, body, com_x, com_y, com_z, ...).
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  {
    std::istringstream lines(testing::readFile(run / "bodies.csv"));
    for (std::string line; std::getline(lines, line);) {
      if (line.empty() || line[0] == '#' || line.rfind("time", 0) == 0) continue;
      std::istringstream cells(line);
      std::vector<std::string> v;
      for (std::string cell; std::getline(cells, cell, ',');) v.push_back(cell);
      REQUIRE(v.size() >= 5);
      centre = {std::stod(v[2]), std::stod(v[3]), std::stod(v[4])};
    }
  }
  const Eigen::Vector2d c = cam.project(centre);
  double radius = 0;  // projected radius: the largest of the projected offsets to the sphere's poles
  for (const Eigen::Vector3d& d : {Eigen::Vector3d(0.03, 0, 0), Eigen::Vector3d(0, 0, 0.03)})
    radius = std::max(radius, (cam.project(centre + d) - c).norm());
  const std::vector<Eigen::Vector2d> red = pixelsOf(img, isRed);
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const auto& p : red) centroid += p;
  if (!red.empty()) centroid /= static_cast<double>(red.size());
  const double disc = 3.14159265 * radius * radius;
  INFO("ball centre " << centre.transpose() << " at pixel " << c.transpose() << ", radius " << radius << " px; "
                      << red.size() << " red pixels (disc " << disc << "), centroid " << centroid.transpose());
  CHECK(red.size() > 0.75 * disc);
  CHECK(red.size() < 1.25 * disc);
  CHECK((centroid - c).norm() < 2.0);

  // The pool: water pixels inside its projected box, which they fill by more than 30 %.
  const std::vector<Eigen::Vector2d> water = pixelsOf(img, isWater);
  const Eigen::Vector4d pool = cam.rect({-0.005, -0.005, -0.005}, {0.205, 0.105, 0.055});
  INFO(water.size() << " water pixels, pool rectangle " << pool.transpose());
  CHECK(water.size() > 0.3 * (pool[2] - pool[0]) * (pool[3] - pool[1]));
  CHECK(inside(water, pool, 1.0) == water.size());
}

// A hand-made folder with a soft body's surface sequence soft_jelly_NNNN.obj (a green cube moving
// along x, the soft-body exporter's naming): render.sh picks it up and the last frame shows the
// cube's green inside its projected box (one pixel of margin), filling more than half of it.
TEST_CASE("render.sh: a soft body's surface sequence is rendered in its colour where it is", "[blender][render]") {
  if (const std::string why = renderSkipReason(); !why.empty()) {
    WARN("SKIPPED: " << why);
    return;
  }
  testing::TempDir tmp;
  testing::writeSoftRun(tmp);
  const int last = testing::kSoftFrames - 1;
  render(tmp.path, std::to_string(last) + ":" + std::to_string(last), 160, 120);
  const io::RgbImage img = io::readPng((tmp.path / "render/frame_0002.png").string());
  const RenderCamera cam = readCamera(tmp.path / "render/camera.json");
  checkNotBlank(img);
  const Eigen::Vector3d c = testing::softCentre(last).cast<double>();
  const Eigen::Vector3d half = Eigen::Vector3d::Constant(0.5 * testing::kSoftSide);
  const Eigen::Vector4d box = cam.rect(c - half, c + half);
  const double area = (box[2] - box[0]) * (box[3] - box[1]);
  const std::vector<Eigen::Vector2d> green = pixelsOf(img, testing::isSoftGreen);
  INFO(green.size() << " green pixels, rectangle " << box.transpose() << " (" << area << " px^2)");
  CHECK(green.size() > 0.5 * area);
  CHECK(inside(green, box, 1.0) == green.size());
}
