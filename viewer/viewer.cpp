// `sphaptics view RUN_DIR`: plays back an output folder (finished or still being written) in a GLFW
// window with OpenGL 3.3 core and a Dear ImGui panel, or writes one frame as a PNG (--screenshot).
//
//   RunData    the folder: particle steps (io::H5PartReader), OBJ sequences, run.json; re-scanned
//              while the run is still going
//   Loader     a thread that reads the requested frame (HDF5 step, OBJ parse) and re-scans the
//              folder, so that the drawing thread never waits on a file: it draws the last frame
//              loaded and uploads the next when it is ready
//   Scene GL   particles as point sprites shaded as spheres, surfaces and bodies as lit meshes,
//              the domain box as lines and its floor as a quad
//   Panel      play / pause / step / timeline, colour mode and legend, layers, camera
//   Live       (liveWindow) the same scene drawing over a running simulation: the newest frame of
//              a LiveMailbox (core/live_frame.h), never waited for; the device's cursor, grasp
//              point and force arrow; a panel with rates, a force plot, gain, smoothing, pause, reset;
//              with the mouse backend (haptics/mouse.h) the left button grabs
#include "viewer/view_options.h"

#include "core/errors.h"
#include "core/mesh.h"
#include "io/h5part_reader.h"
#include "io/obj_io.h"
#include "io/png.h"
#include "io/run_folder.h"
#include "viewer/camera.h"

#include <GL/gl.h>
#include <GL/glext.h>
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace sph::viewer {

namespace fs = std::filesystem;

namespace {

enum class ColourBy { Phase = 0, Pressure = 1, Speed = 2, Density = 3 };
const char* const kColourLabels[] = {"phase colour", "pressure (Pa)", "speed (m/s)", "density (kg/m^3)"};

/// A failure to open a window or to set up OpenGL (exit code 3).
struct WindowError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// -----------------------------------------------------------------------------------------------
// The run folder

/// One loaded mesh of an OBJ sequence at the current frame.
struct LoadedMesh {
  std::string name;           ///< sequence name (fluid_water, body_ball)
  bool body = false;
  Eigen::Vector3f colour;     ///< linear RGB (when the mesh has no per-vertex colours)
  bool vertex_colours = false;  ///< the OBJ has per-vertex colours (`v x y z r g b`)
  std::vector<float> vertices;  ///< (triangles x 3 corners) x (position 3, normal 3, colour 3)
};

/// Triangles as (position, normal, colour) per corner; vertex normals from the mesh, else face
/// normals; vertex colours from the mesh, else white (the draw call then uses the mesh's colour).
void flattenMesh(const TriMesh& mesh, std::vector<float>& out) {
  const bool has_normals = mesh.normals.size() == mesh.positions.size() && !mesh.normals.empty();
  const bool has_colours = mesh.colours.size() == mesh.positions.size() && !mesh.colours.empty();
  out.reserve(out.size() + mesh.triangles.size() * 27);
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f& a = mesh.positions[t[0]];
    const Eigen::Vector3f face = (mesh.positions[t[1]] - a).cross(mesh.positions[t[2]] - a).normalized();
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f& p = mesh.positions[t[static_cast<std::size_t>(k)]];
      const Eigen::Vector3f n = has_normals ? mesh.normals[t[static_cast<std::size_t>(k)]] : face;
      const Eigen::Vector3f c = has_colours ? mesh.colours[t[static_cast<std::size_t>(k)]] : Eigen::Vector3f::Ones();
      out.insert(out.end(), {p.x(), p.y(), p.z(), n.x(), n.y(), n.z(), c.x(), c.y(), c.z()});
    }
  }
}

/// The folder's content as of the last scan.
class RunData {
 public:
  // Threads: the files (HDF5 above all, which is not thread-safe) are read by one thread at a
  // time: the constructor's, then the loader's (rescan, particles, meshes). The drawing thread
  // reads only the copies that rescan leaves under the mutex: info(), running(), frames(), bounds().
  explicit RunData(std::string dir) : dir_(std::move(dir)) {
    rescan();
    bounds_ = computeBounds();
  }

  /// Re-reads run.json, reopens the particle file and lists the OBJ sequences (for a run still
  /// being written). A particle file that cannot be opened just now keeps the previous count.
  void rescan() {
    io::RunFolderInfo info = io::readRunFolderInfo(dir_);
    const std::string file = io::particlesFile(dir_);
    if (!file.empty()) {
      try {
        reader_ = std::make_unique<io::H5PartReader>(file);
      } catch (const std::runtime_error&) {
        // Being created or renamed this instant: try again at the next scan.
      }
    }
    sequences_ = io::scanObjSequences(dir_);
    // Frames available: the most of the particle steps and the OBJ sequences' frames.
    int n = reader_ ? reader_->steps() : 0;
    for (const auto& s : sequences_)
      if (!s.frames.empty()) n = std::max(n, s.frames.rbegin()->first + 1);
    std::lock_guard<std::mutex> lock(mutex_);
    info_ = std::move(info);
    frames_ = n;
  }

  io::RunFolderInfo info() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return info_;
  }
  bool running() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return info_.status == "running";
  }
  int frames() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return frames_;
  }

  /// Particles of frame k (an empty frame when the file has no such step).
  ParticleFrame particles(int k) const {
    if (!reader_ || k >= reader_->steps()) return {};
    return reader_->readStep(k);
  }

  /// Meshes of frame k from the OBJ sequences (fluid surfaces, bodies, or both), as flat
  /// triangle lists with normals.
  std::vector<LoadedMesh> meshes(int k, bool surfaces = true, bool bodies = true) const {
    std::vector<LoadedMesh> out;
    for (const auto& s : sequences_) {
      if (s.body ? !bodies : !surfaces) continue;
      const auto it = s.frames.find(k);
      if (it == s.frames.end()) continue;
      LoadedMesh m;
      m.name = s.name;
      m.body = s.body;
      m.colour = colourOf(s);  // info_ is written only by this thread (rescan)
      const TriMesh mesh = io::readObj(it->second, /*allow_empty=*/true);
      m.vertex_colours = !mesh.colours.empty();
      flattenMesh(mesh, m.vertices);
      out.push_back(std::move(m));
    }
    return out;
  }

  /// Domain box: run.json's, else the bounds of the particles and meshes of frame 0 (at the start).
  std::pair<Eigen::Vector3f, Eigen::Vector3f> bounds() const { return bounds_; }

  /// Particle radius for the sprites: half the spacing (unit: m).
  float particleRadius(const ParticleFrame& f) const {
    if (info_.particle_spacing > 0) return static_cast<float>(0.5 * info_.particle_spacing);
    // Without run.json: the spacing of n particles filling their bounding box.
    const auto [lo, hi] = bounds_;
    const float volume = std::max((hi - lo).prod(), 1e-9f);
    return 0.5f * std::cbrt(volume / static_cast<float>(std::max<std::size_t>(f.size(), 1)));
  }

 private:
  std::pair<Eigen::Vector3f, Eigen::Vector3f> computeBounds() const {
    if (info_.has_domain) return {info_.domain_min, info_.domain_max};
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
    const ParticleFrame p = particles(0);
    for (std::size_t i = 0; i < p.size(); ++i) {
      lo = lo.cwiseMin(Eigen::Vector3f(p.x[i], p.y[i], p.z[i]));
      hi = hi.cwiseMax(Eigen::Vector3f(p.x[i], p.y[i], p.z[i]));
    }
    for (const auto& m : meshes(0))
      for (std::size_t i = 0; i + 8 < m.vertices.size(); i += 9) {
        lo = lo.cwiseMin(Eigen::Vector3f(m.vertices[i], m.vertices[i + 1], m.vertices[i + 2]));
        hi = hi.cwiseMax(Eigen::Vector3f(m.vertices[i], m.vertices[i + 1], m.vertices[i + 2]));
      }
    if (!(lo.array() <= hi.array()).all()) return {Eigen::Vector3f::Zero(), Eigen::Vector3f::Ones()};
    return {lo, hi};
  }

  /// A sequence's colour: its body's, cloth's, soft body's or phase's colour from run.json, else a
  /// default per kind.
  Eigen::Vector3f colourOf(const io::ObjSequence& s) const {
    const std::size_t prefix = s.cloth ? 6 : s.soft ? 5 : s.body ? 5 : 6;  // "cloth_", "soft_", "body_", "fluid_"
    const std::string key = s.name.substr(prefix);
    const auto& named = s.cloth ? info_.cloths : s.soft ? info_.soft_bodies : s.body ? info_.bodies : info_.phases;
    for (const auto& [name, colour] : named) {
      std::string sanitised = name;  // as io::surfaceObjName writes phase names
      for (char& c : sanitised)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') c = '_';
      if (name == key || sanitised == key) return colour;
    }
    if (s.cloth) return {0.8f, 0.3f, 0.3f};
    if (s.soft) return {0.85f, 0.55f, 0.5f};
    return s.body ? Eigen::Vector3f(0.7f, 0.7f, 0.7f) : Eigen::Vector3f(0.2f, 0.4f, 0.9f);
  }

  std::string dir_;
  mutable std::mutex mutex_;  // guards info_ and frames_ (written by rescan, read by the drawing thread)
  io::RunFolderInfo info_;
  int frames_ = 0;
  std::pair<Eigen::Vector3f, Eigen::Vector3f> bounds_;
  std::unique_ptr<io::H5PartReader> reader_;
  std::vector<io::ObjSequence> sequences_;
};

/// One frame read by the loader: particles and the meshes of the layers asked for.
struct LoadedFrame {
  int k = 0;
  std::array<bool, 2> layers{false, false};  ///< surfaces, bodies read
  ParticleFrame particles;
  std::vector<LoadedMesh> meshes;
  float radius = 0.005f;                     ///< sprite radius (unit: m)
  std::string error;                         ///< the frame could not be read (still being written)
};

/// The loader thread: reads the newest requested frame and re-scans a running run's folder twice a
/// second; the drawing thread asks (request) and collects (take) without waiting.
class FrameLoader {
 public:
  explicit FrameLoader(RunData& run) : run_(run), thread_([this] { loop(); }) {}
  ~FrameLoader() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  FrameLoader(const FrameLoader&) = delete;
  FrameLoader& operator=(const FrameLoader&) = delete;

  /// Asks for frame k with these layers (a newer request replaces one not yet started).
  void request(int k, std::array<bool, 2> layers) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (pending_ && want_k_ == k && want_layers_ == layers) return;
    want_k_ = k;
    want_layers_ = layers;
    pending_ = true;
    cv_.notify_all();
  }
  /// The frame loaded since the last call, if any.
  std::unique_ptr<LoadedFrame> take() {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::move(ready_);
  }

 private:
  void loop() {
    auto last_scan = std::chrono::steady_clock::now();
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stop_) {
      cv_.wait_for(lock, std::chrono::milliseconds(100), [this] { return stop_ || pending_; });
      if (stop_) break;
      const auto now = std::chrono::steady_clock::now();
      const bool scan = now - last_scan > std::chrono::milliseconds(500) && run_.running();
      if (!pending_ && !scan) continue;
      const bool load = pending_;
      const int k = want_k_;
      const std::array<bool, 2> layers = want_layers_;
      pending_ = false;
      lock.unlock();
      // Off the drawing thread: the folder scan, the HDF5 step, the OBJ parse.
      if (scan) {
        run_.rescan();
        last_scan = now;
      }
      std::unique_ptr<LoadedFrame> f;
      if (load) {
        f = std::make_unique<LoadedFrame>();
        f->k = k;
        f->layers = layers;
        try {
          f->particles = run_.particles(k);
          // Hidden layers are not read (a surface OBJ of 50k particles takes longer than the particles).
          f->meshes = run_.meshes(k, layers[0], layers[1]);
          f->radius = run_.particleRadius(f->particles);
        } catch (const std::exception& e) {
          f->error = e.what();
        }
      }
      lock.lock();
      if (f) ready_ = std::move(f);
    }
  }

  RunData& run_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false, pending_ = false;
  int want_k_ = 0;
  std::array<bool, 2> want_layers_{false, false};
  std::unique_ptr<LoadedFrame> ready_;
  std::thread thread_;  // last: starts after the members it uses
};

// -----------------------------------------------------------------------------------------------
// Colours

/// Linear RGB from sRGB (IEC 61966-2-1), so that colour maps given in sRGB survive the shader's
/// linear -> sRGB conversion.
float srgbToLinear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

/// Viridis colour map (van der Walt & Smith, matplotlib) through five of its sRGB samples, linear in
/// between; t in [0, 1]; returns linear RGB.
Eigen::Vector3f viridis(float t) {
  static const float keys[5][3] = {{0x44, 0x01, 0x54}, {0x3b, 0x52, 0x8b}, {0x21, 0x91, 0x8c}, {0x5e, 0xc9, 0x62}, {0xfd, 0xe7, 0x25}};
  t = std::clamp(t, 0.0f, 1.0f) * 4.0f;
  const int i = std::min(static_cast<int>(t), 3);
  const float u = t - static_cast<float>(i);
  Eigen::Vector3f c;
  for (int ch = 0; ch < 3; ++ch)
    c[ch] = srgbToLinear(((1 - u) * keys[i][ch] + u * keys[i + 1][ch]) / 255.0f);
  return c;
}

/// The scalar a colour mode shows for particle i.
float scalarOf(const ParticleFrame& f, std::size_t i, ColourBy by) {
  switch (by) {
    case ColourBy::Pressure: return f.pressure[i];
    case ColourBy::Speed: return std::sqrt(f.vx[i] * f.vx[i] + f.vy[i] * f.vy[i] + f.vz[i] * f.vz[i]);
    case ColourBy::Density: return f.density[i];
    case ColourBy::Phase: break;
  }
  return 0.0f;
}

// -----------------------------------------------------------------------------------------------
// OpenGL

const char* const kPointVs = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 colour;
uniform mat4 view;
uniform mat4 projection;
uniform float radius;     // sphere radius (m)
uniform float viewport_h; // viewport height (pixels)
out vec3 v_colour;
void main() {
  gl_Position = projection * view * vec4(position, 1.0);
  // Projected diameter of a sphere of this radius at this depth.
  gl_PointSize = max(2.0, viewport_h * projection[1][1] * radius / gl_Position.w);
  v_colour = colour;
})";

// Point sprite shaded as a sphere: the normal from the sprite coordinate, a head light plus ambient.
const char* const kPointFs = R"(#version 330 core
in vec3 v_colour;
out vec4 frag;
void main() {
  vec2 d = gl_PointCoord * 2.0 - 1.0;
  float r2 = dot(d, d);
  if (r2 > 1.0) discard;
  vec3 n = vec3(d.x, -d.y, sqrt(1.0 - r2));
  float light = 0.35 + 0.65 * max(dot(n, normalize(vec3(0.3, 0.5, 1.0))), 0.0);
  frag = vec4(pow(v_colour * light, vec3(1.0 / 2.2)), 1.0);
})";

const char* const kMeshVs = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec3 vertex_colour;
uniform mat4 view;
uniform mat4 projection;
out vec3 v_normal;
out vec3 v_colour;
void main() {
  gl_Position = projection * view * vec4(position, 1.0);
  v_normal = mat3(view) * normal;
  v_colour = vertex_colour;
})";

// Two-sided Lambert in eye space, the light over the viewer's shoulder.
const char* const kMeshFs = R"(#version 330 core
in vec3 v_normal;
in vec3 v_colour;
uniform vec3 colour;
uniform float lit;             // 1: shaded, 0: flat colour (lines)
uniform float vertex_colours;  // 1: the per-vertex colour, 0: the uniform colour
out vec4 frag;
void main() {
  vec3 n = normalize(v_normal);
  float light = mix(1.0, 0.3 + 0.7 * abs(dot(n, normalize(vec3(0.3, 0.5, 1.0)))), lit);
  vec3 base = mix(colour, v_colour, vertex_colours);
  frag = vec4(pow(base * light, vec3(1.0 / 2.2)), 1.0);
})";

GLuint compileProgram(const char* vs_src, const char* fs_src) {
  auto shader = [](GLenum type, const char* src) {
    const GLuint s = glCreateShader(type);
    glShaderSource(s, 1, &src, nullptr);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
      char log[2048];
      glGetShaderInfoLog(s, sizeof log, nullptr, log);
      throw WindowError(std::string("OpenGL shader does not compile: ") + log);
    }
    return s;
  };
  const GLuint vs = shader(GL_VERTEX_SHADER, vs_src), fs = shader(GL_FRAGMENT_SHADER, fs_src);
  const GLuint p = glCreateProgram();
  glAttachShader(p, vs);
  glAttachShader(p, fs);
  glLinkProgram(p);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    throw WindowError(std::string("OpenGL program does not link: ") + log);
  }
  return p;
}

/// A vertex array of interleaved float attributes: 3 + 3 floats per vertex (particles, lines), or
/// 3 + 3 + 3 (meshes: position, normal, colour).
struct VertexBuffer {
  GLuint vao = 0, vbo = 0;
  GLsizei count = 0;
  int floats = 6;  ///< per vertex
  void create(int floats_per_vertex = 6) {
    floats = floats_per_vertex;
    const GLsizei stride = floats * static_cast<GLsizei>(sizeof(float));
    glGenVertexArrays(1, &vao);
    glGenBuffers(1, &vbo);
    glBindVertexArray(vao);
    glBindBuffer(GL_ARRAY_BUFFER, vbo);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(3 * sizeof(float)));
    if (floats >= 9) {
      glEnableVertexAttribArray(2);
      glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(6 * sizeof(float)));
    }
    glBindVertexArray(0);
  }
  void upload(const std::vector<float>& data) {
    glBindBuffer(GL_ARRAY_BUFFER, vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)), data.data(), GL_DYNAMIC_DRAW);
    count = static_cast<GLsizei>(data.size() / static_cast<std::size_t>(floats));
  }
  void destroy() {
    if (vbo) glDeleteBuffers(1, &vbo);
    if (vao) glDeleteVertexArrays(1, &vao);
    vao = vbo = 0;
  }
};

// -----------------------------------------------------------------------------------------------
// The viewer

struct Layers {
  bool particles = true, surfaces = true, bodies = true, box = true;
};

class Viewer {
 public:
  Viewer(const ViewOptions& opt, RunData* run, std::shared_ptr<LiveLink> live = nullptr,
         std::shared_ptr<haptics::MouseInput> mouse = nullptr)
      : opt_(opt), run_(run), live_(std::move(live)), mouse_in_(std::move(mouse)) {
    if (live_) live_scene_ = live_->mailbox.scene();
    for (const std::string& h : opt.hide) {
      if (h == "particles") layers_.particles = false;
      if (h == "surfaces") layers_.surfaces = false;
      if (h == "bodies") layers_.bodies = false;
      if (h == "box") layers_.box = false;
    }
    const auto& names = viewColourNames();
    colour_ = static_cast<ColourBy>(std::find(names.begin(), names.end(), opt.colour) - names.begin());
    point_scale_ = static_cast<float>(opt.particle_size);
  }

  /// Creates the window (hidden for a screenshot) and the OpenGL objects.
  void open(bool visible) {
    glfwSetErrorCallback([](int, const char* text) { std::cerr << "GLFW: " << text << "\n"; });
    if (!glfwInit())
      throw WindowError("cannot open a window: no display (set DISPLAY, or run under `xvfb-run -a` for --screenshot)");
    glfw_ = true;
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_VISIBLE, visible ? GLFW_TRUE : GLFW_FALSE);
    const std::string title = (live_ ? "sphaptics run " : "sphaptics view ") + opt_.dir;
    window_ = glfwCreateWindow(opt_.width, opt_.height, title.c_str(), nullptr, nullptr);
    if (!window_) throw WindowError("cannot open an OpenGL 3.3 core window (GLFW reported why above)");
    glfwMakeContextCurrent(window_);
    glfwSwapInterval(opt_.benchmark > 0 ? 0 : 1);
    glfwSetWindowUserPointer(window_, this);
    // Wheel zoom (installed before ImGui, which chains to it).
    glfwSetScrollCallback(window_, [](GLFWwindow* w, double, double dy) {
      auto* self = static_cast<Viewer*>(glfwGetWindowUserPointer(w));
      self->scroll_ += static_cast<float>(dy);
      self->input_seen_ = true;
    });
    // Any input marks the live window for redrawing (it otherwise redraws only for a new frame).
    glfwSetCursorPosCallback(window_, [](GLFWwindow* w, double, double) {
      static_cast<Viewer*>(glfwGetWindowUserPointer(w))->input_seen_ = true;
    });
    glfwSetMouseButtonCallback(window_, [](GLFWwindow* w, int, int, int) {
      static_cast<Viewer*>(glfwGetWindowUserPointer(w))->input_seen_ = true;
    });
    glfwSetKeyCallback(window_, [](GLFWwindow* w, int, int, int, int) {
      static_cast<Viewer*>(glfwGetWindowUserPointer(w))->input_seen_ = true;
    });
    glfwSetWindowSizeCallback(window_, [](GLFWwindow* w, int, int) {
      static_cast<Viewer*>(glfwGetWindowUserPointer(w))->input_seen_ = true;
    });

    // ImGui with its GLFW and OpenGL 3 backends.
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the user's folder
    ImGui::StyleColorsDark();
    ImGui_ImplGlfw_InitForOpenGL(window_, true);
    ImGui_ImplOpenGL3_Init("#version 330 core");
    imgui_ = true;

    // Programs and buffers.
    point_program_ = compileProgram(kPointVs, kPointFs);
    mesh_program_ = compileProgram(kMeshVs, kMeshFs);
    particles_.create();
    box_.create();
    floor_.create();
    buildBox();
    overlay_points_.create();
    overlay_lines_.create();
    const auto [lo, hi] = bounds();
    camera_.frame(lo, hi, static_cast<float>(opt_.width) / static_cast<float>(opt_.height));
  }

  ~Viewer() {
    if (window_) {
      glfwMakeContextCurrent(window_);
      particles_.destroy();
      box_.destroy();
      floor_.destroy();
      overlay_points_.destroy();
      overlay_lines_.destroy();
      for (auto& m : mesh_buffers_) m.destroy();
      if (point_program_) glDeleteProgram(point_program_);
      if (mesh_program_) glDeleteProgram(mesh_program_);
      if (fbo_) glDeleteFramebuffers(1, &fbo_);
      if (rbo_[0]) glDeleteRenderbuffers(2, rbo_);
    }
    if (imgui_) {
      ImGui_ImplOpenGL3_Shutdown();
      ImGui_ImplGlfw_Shutdown();
      ImGui::DestroyContext();
    }
    if (window_) glfwDestroyWindow(window_);
    if (glfw_) glfwTerminate();
  }
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  /// Renders frame k into an off-screen framebuffer of the requested size and writes the PNG.
  void screenshot(int k, const std::string& path) {
    load(k);
    // Off-screen colour and depth targets: a hidden window's own framebuffer is not reliable.
    glGenFramebuffers(1, &fbo_);
    glGenRenderbuffers(2, rbo_);
    glBindRenderbuffer(GL_RENDERBUFFER, rbo_[0]);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, opt_.width, opt_.height);
    glBindRenderbuffer(GL_RENDERBUFFER, rbo_[1]);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, opt_.width, opt_.height);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, rbo_[0]);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, rbo_[1]);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw WindowError("cannot create an off-screen OpenGL framebuffer");

    // The scene, then the legend (no panel) through ImGui.
    drawScene(opt_.width, opt_.height);
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::GetIO().DisplaySize = ImVec2(static_cast<float>(opt_.width), static_cast<float>(opt_.height));
    ImGui::NewFrame();
    drawLegend();
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());

    writeFramebuffer(opt_.width, opt_.height, path);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
  }

  /// Reads the bound framebuffer back (bottom-up in OpenGL), flips it and writes a PNG.
  static void writeFramebuffer(int width, int height, const std::string& path) {
    io::RgbImage img;
    img.width = width;
    img.height = height;
    img.rgb.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
    std::vector<uint8_t> rows(img.rgb.size());
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, rows.data());
    const std::size_t stride = static_cast<std::size_t>(width) * 3;
    for (int y = 0; y < height; ++y)
      std::copy_n(&rows[static_cast<std::size_t>(height - 1 - y) * stride], stride, &img.rgb[static_cast<std::size_t>(y) * stride]);
    io::writePng(path, img);
  }

  /// The interactive loop; with opt.benchmark > 0 plays for that long and returns the frame rate.
  double loop(int first) {
    frame_ = first;
    load(frame_);
    if (opt_.benchmark > 0) playing_ = true;
    FrameLoader loader(*run_);
    double last = glfwGetTime(), accumulator = 0;
    const double t0 = last;
    long drawn = 0;
    int known_frames = run_->frames();
    while (!glfwWindowShouldClose(window_)) {
      glfwPollEvents();
      const double now = glfwGetTime();
      // Playback clock: frames advance at the playback rate, looping at the end.
      const double rate = playbackRate();
      if (playing_ && run_->frames() > 0) {
        accumulator += (now - last) * rate;
        while (accumulator >= 1.0) {
          accumulator -= 1.0;
          frame_ = (frame_ + 1 < run_->frames()) ? frame_ + 1 : (loop_ || opt_.benchmark > 0 ? 0 : frame_);
        }
      }
      last = now;
      // A run still being written (the loader re-scans it): follow new frames.
      if (const int n = run_->frames(); n > known_frames) {
        if (follow_) frame_ = n - 1;
        known_frames = n;
      }
      // Ask the loader for the frame to show; upload whatever it has finished meanwhile.
      const std::array<bool, 2> want{layers_.surfaces, layers_.bodies};
      if (frame_ != loaded_ || loaded_layers_ != want) loader.request(frame_, want);
      if (std::unique_ptr<LoadedFrame> f = loader.take()) {
        apply(std::move(*f));
        ++shown_;
      }

      int w = 0, h = 0;
      glfwGetFramebufferSize(window_, &w, &h);
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      handleInput(h);
      drawPanel();
      drawLegend();
      ImGui::Render();
      glBindFramebuffer(GL_FRAMEBUFFER, 0);
      drawScene(w, h);
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      glfwSwapBuffers(window_);
      ++drawn;
      if (opt_.benchmark > 0 && now - t0 >= opt_.benchmark) break;
    }
    const double elapsed = glfwGetTime() - t0;
    shown_rate_ = elapsed > 0 ? static_cast<double>(shown_) / elapsed : 0.0;
    return elapsed > 0 ? static_cast<double>(drawn) / elapsed : 0.0;
  }

  /// Live: draws the newest published frame until the window closes or run_done() is true (then
  /// the last frame stays up for `linger` seconds); returns the window's frame rate.
  double liveLoop(const std::function<bool()>& run_done, const std::string& screenshot = "") {
    const double t0 = glfwGetTime();
    long drawn = 0;
    if (mouse_in_) sendCamera(/*reset_depth=*/true);
    int redraws = 3;  // pictures still to draw: one per new frame, three after input (ImGui settles over a few)
    while (!glfwWindowShouldClose(window_)) {
      // Wait for input for up to 1/60 s: the window draws only for a new frame or input, so that on
      // a machine without a GPU (software OpenGL) it takes no processor time from the simulation
      // while nothing changes.
      glfwWaitEventsTimeout(1.0 / 60.0);
      // The newest frame, if it is new: the simulation has published it and never waits for us.
      if (auto f = live_->mailbox.latest(); f && f != live_frame_) {
        loadLive(std::move(f));
        redraws = std::max(redraws, 1);
      }
      if (input_seen_) {
        input_seen_ = false;
        redraws = std::max(redraws, 3);
      }
      const bool last = run_done() && (!live_frame_ || live_frame_->finished || live_->mailbox.latest() == live_frame_);
      if (redraws == 0 && !last) continue;
      --redraws;

      int w = 0, h = 0;
      glfwGetFramebufferSize(window_, &w, &h);
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      handleInput(h);
      drawLivePanel();
      drawLegend();
      ImGui::Render();
      glBindFramebuffer(GL_FRAMEBUFFER, 0);
      drawScene(w, h);
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      // The run's last picture, panel included, as a PNG (before the swap, from the back buffer).
      if (last && !screenshot.empty()) {
        glReadBuffer(GL_BACK);
        writeFramebuffer(w, h, screenshot);
      }
      glfwSwapBuffers(window_);
      ++drawn;
      if (last) break;
    }
    // Closing the window ends the run.
    live_->controls.stop = true;
    const double elapsed = glfwGetTime() - t0;
    shown_rate_ = elapsed > 0 ? static_cast<double>(samples_total_) / elapsed : 0.0;
    return elapsed > 0 ? static_cast<double>(drawn) / elapsed : 0.0;
  }

 private:
  /// Live: takes a published frame: particles, bodies at their poses, cloths, the device overlay.
  void loadLive(std::shared_ptr<const LiveFrame> f) {
    live_frame_ = std::move(f);
    const LiveFrame& fr = *live_frame_;
    if (!live_scene_) live_scene_ = live_->mailbox.scene();
    radius_ = live_scene_ ? live_scene_->particle_radius : 0.005f;
    uploadParticles();
    // Bodies (body-frame meshes moved to their poses) and cloths, as the playback's meshes.
    meshes_.clear();
    if (live_scene_) {
      for (std::size_t b = 0; b < live_scene_->body_meshes.size() && b < fr.body_positions.size(); ++b) {
        TriMesh world = live_scene_->body_meshes[b];
        for (auto& p : world.positions) p = fr.body_orientations[b] * p + fr.body_positions[b];
        for (auto& n : world.normals) n = fr.body_orientations[b] * n;
        LoadedMesh m;
        m.name = "body_" + live_scene_->body_names[b];
        m.body = true;
        m.colour = live_scene_->body_colours[b];
        flattenMesh(world, m.vertices);
        meshes_.push_back(std::move(m));
      }
      for (std::size_t c = 0; c < fr.cloths.size(); ++c) {
        LoadedMesh m;
        m.name = "cloth";
        m.body = true;
        m.colour = c < live_scene_->cloth_colours.size() ? live_scene_->cloth_colours[c] : Eigen::Vector3f(0.8f, 0.3f, 0.3f);
        flattenMesh(fr.cloths[c], m.vertices);
        meshes_.push_back(std::move(m));
      }
    }
    for (auto& b : mesh_buffers_) b.destroy();
    mesh_buffers_.assign(meshes_.size(), VertexBuffer{});
    for (std::size_t i = 0; i < meshes_.size(); ++i) {
      mesh_buffers_[i].create(9);
      mesh_buffers_[i].upload(meshes_[i].vertices);
    }
    // The device overlay: cursor and grasp point (sprites), the spring between them and the force
    // arrow from the grasp point (lines, arrow_scale_ metres per newton).
    const LiveHaptics& hp = fr.haptics;
    if (live_scene_ && live_scene_->haptics) {
      const Eigen::Vector3f c = hp.cursor.cast<float>(), g = hp.grasp.cast<float>();
      std::vector<float> pts{c.x(), c.y(), c.z(), 0.2f, 0.9f, 0.9f};
      if (hp.held >= 0) pts.insert(pts.end(), {g.x(), g.y(), g.z(), 0.95f, 0.2f, 0.8f});
      overlay_points_.upload(pts);
      std::vector<float> lines{c.x(), c.y(), c.z(), 0, 0, 1, g.x(), g.y(), g.z(), 0, 0, 1};
      overlay_spring_ = 2;
      const Eigen::Vector3f from = hp.held >= 0 ? g : c;
      const Eigen::Vector3f d = arrow_scale_ * hp.force.cast<float>();
      if (d.norm() > 1e-6f) {
        const Eigen::Vector3f tip = from + d;
        // Two barbs at 25 % of the length, in a plane containing the arrow.
        const Eigen::Vector3f side = d.cross(std::abs(d.z()) < 0.9f * d.norm() ? Eigen::Vector3f::UnitZ() : Eigen::Vector3f::UnitX()).normalized();
        const Eigen::Vector3f b1 = tip - 0.25f * d + 0.12f * d.norm() * side, b2 = tip - 0.25f * d - 0.12f * d.norm() * side;
        lines.insert(lines.end(), {from.x(), from.y(), from.z(), 0, 0, 1, tip.x(), tip.y(), tip.z(), 0, 0, 1,
                                   tip.x(), tip.y(), tip.z(), 0, 0, 1, b1.x(), b1.y(), b1.z(), 0, 0, 1,
                                   tip.x(), tip.y(), tip.z(), 0, 0, 1, b2.x(), b2.y(), b2.z(), 0, 0, 1});
      }
      overlay_lines_.upload(lines);
    }
    // Statistics over the last 10 s of frames.
    samples_.push_back({glfwGetTime(), fr.time, hp.servo_seconds, hp.force.norm(), fr.frame, hp.servo_ticks});
    ++samples_total_;
    while (samples_.size() > 2 && samples_.back().wall - samples_.front().wall > 10.0) samples_.pop_front();
    if (!settings_read_ && live_scene_ && live_scene_->haptics) {
      gain_ = static_cast<float>(hp.gain);
      smoothing_ = hp.smoothing;
      settings_read_ = true;
    }
  }

  /// Live: rates over the last second of samples: (simulation frames/s, simulated s per s, servo Hz).
  std::array<double, 3> liveRates() const {
    if (samples_.size() < 2) return {0, 0, 0};
    const Sample& b = samples_.back();
    std::size_t i = samples_.size() - 1;
    while (i > 0 && b.wall - samples_[i].wall < 1.0) --i;
    const Sample& a = samples_[i];
    const double dt = std::max(b.wall - a.wall, 1e-9);
    const double servo_dt = b.servo_seconds - a.servo_seconds;
    return {(b.frame - a.frame) / dt, (b.time - a.time) / dt,
            servo_dt > 0 ? static_cast<double>(b.ticks - a.ticks) / servo_dt : 0.0};
  }

  /// Live: the panel: rates, force plot, gain and smoothing, pause and reset, view settings.
  void drawLivePanel() {
    ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
    ImGui::SetNextWindowSize(ImVec2(390, 0), ImGuiCond_FirstUseEver);
    ImGui::Begin("sphaptics live");
    ImGui::TextWrapped("%s", opt_.dir.c_str());
    const LiveFrame* f = live_frame_.get();
    if (!f) {
      ImGui::TextUnformatted("waiting for the first frame ...");
    } else {
      const auto r = liveRates();
      ImGui::Text("frame %d   t = %.3f s   %zu particles%s", f->frame, f->time, f->particles.size(), f->finished ? "   (finished)" : "");
      ImGui::Text("simulation: %.1f frames/s (%.2f x real time)", r[0], r[1]);
      if (live_scene_ && live_scene_->haptics) {
        const LiveHaptics& hp = f->haptics;
        ImGui::Text("servo: %.0f Hz   |F| = %.3f N", r[2], hp.force.norm());
        ImGui::Text("held: %s", hp.held >= 0 && live_scene_ && static_cast<std::size_t>(hp.held) < live_scene_->body_names.size()
                                    ? live_scene_->body_names[static_cast<std::size_t>(hp.held)].c_str() : "nothing");
        // |F| over the last seconds (one sample per frame received).
        std::vector<float> plot;
        for (const Sample& s : samples_) plot.push_back(static_cast<float>(s.force));
        char label[64];
        std::snprintf(label, sizeof label, "|F| last %.0f s", samples_.empty() ? 0.0 : samples_.back().wall - samples_.front().wall);
        float top = 0.5f;
        for (float v : plot) top = std::max(top, v);
        ImGui::PlotLines("##force", plot.data(), static_cast<int>(plot.size()), 0, label, 0.0f, top * 1.1f, ImVec2(0, 70));
        ImGui::Text("force axis 0 to %.2f N", static_cast<double>(top * 1.1f));
        if (ImGui::SliderFloat("gain", &gain_, 0.0f, 10.0f, "%.2f")) live_->controls.gain = gain_;
        // The paper's rolling average over N frames, or 0: the servo's own smoothing.
        if (ImGui::SliderInt("smoothing (frames)", &smoothing_, 0, 60, smoothing_ == 0 ? "servo" : "%d"))
          live_->controls.smoothing = smoothing_;
        ImGui::SliderFloat("arrow (m/N)", &arrow_scale_, 0.005f, 1.0f, "%.3f", ImGuiSliderFlags_Logarithmic);
      }
    }
    if (ImGui::Checkbox("pause (P)", &paused_)) live_->controls.paused = paused_;
    ImGui::SameLine();
    if (ImGui::Button("reset (R)")) requestReset();

    int mode = static_cast<int>(colour_);
    if (ImGui::Combo("colour", &mode, kColourLabels, 4)) {
      colour_ = static_cast<ColourBy>(mode);
      fix_range_ = false;
      if (live_frame_) uploadParticles();
    }
    ImGui::SliderFloat("particle size", &point_scale_, 0.2f, 3.0f, "%.2f x");
    ImGui::Checkbox("particles (1)", &layers_.particles);
    ImGui::SameLine();
    ImGui::Checkbox("bodies (3)", &layers_.bodies);
    ImGui::SameLine();
    ImGui::Checkbox("box (4)", &layers_.box);
    if (ImGui::Button("frame the domain (F)")) resetCamera();
    ImGui::Text("window: %.0f frames/s", static_cast<double>(ImGui::GetIO().Framerate));
    if (ImGui::CollapsingHeader("mouse and keys"))
      ImGui::TextUnformatted(mouse_in_ ? "left: grab (the cursor moves a point in the plane facing you)\n"
                                         "wheel: that plane nearer / farther   shift + wheel: zoom\n"
                                         "right drag: orbit   middle drag: pan\nP: pause   R: reset   Q / Esc: quit"
                                       : "left drag: orbit   right / middle drag: pan\nwheel: zoom   P: pause   R: reset\n"
                                         "1, 3, 4: layers   C: colour   F: frame   Q / Esc: quit");
    ImGui::End();
  }

  void requestReset() {
    live_->controls.reset = true;
    samples_.clear();
    settings_read_ = false;
  }

  /// Live with the mouse backend: the camera the cursor is read in (when it changed).
  void sendCamera(bool reset_depth) {
    int ww = 0, wh = 0;
    glfwGetWindowSize(window_, &ww, &wh);
    const Eigen::Vector3f e = camera_.eye(), f = (camera_.target - e).normalized();
    const double key[8] = {e.x(), e.y(), e.z(), camera_.target.x(), camera_.target.y(), camera_.target.z(),
                           static_cast<double>(ww), static_cast<double>(wh)};
    if (!reset_depth && std::equal(key, key + 8, last_camera_)) return;
    std::copy(key, key + 8, last_camera_);
    haptics::MouseEvent ev;
    ev.kind = haptics::MouseEvent::Kind::Camera;
    ev.camera.eye = e.cast<double>();
    ev.camera.forward = f.cast<double>();
    const Eigen::Vector3f r = f.cross(Eigen::Vector3f::UnitZ()).normalized();
    ev.camera.right = r.cast<double>();
    ev.camera.up = r.cross(f).cast<double>();
    ev.camera.fovy = camera_.fovy;
    ev.camera.width = ww;
    ev.camera.height = wh;
    // The plane through the orbit target to begin with; the wheel moves it later.
    if (reset_depth) ev.depth = camera_.distance;
    mouse_in_->push(ev);
  }

  /// The domain box: the run folder's, or the live scene's.
  std::pair<Eigen::Vector3f, Eigen::Vector3f> bounds() const {
    if (run_) return run_->bounds();
    if (live_scene_) return {live_scene_->domain_min, live_scene_->domain_max};
    return {Eigen::Vector3f::Zero(), Eigen::Vector3f::Ones()};
  }

  /// The particles on screen.
  const ParticleFrame& shown() const { return live_frame_ ? live_frame_->particles : current_; }

  double playbackRate() const {
    if (fps_ > 0) return fps_;
    if (opt_.fps > 0) return opt_.fps;
    return run_->info().frame_rate > 0 ? run_->info().frame_rate : 30.0;
  }

  /// Reads frame k (particles and meshes) on this thread and uploads it (screenshots, the first frame).
  void load(int k) {
    LoadedFrame f;
    f.k = k;
    f.layers = {layers_.surfaces, layers_.bodies};
    try {
      f.particles = run_->particles(k);
      f.meshes = run_->meshes(k, layers_.surfaces, layers_.bodies);
      f.radius = run_->particleRadius(f.particles);
    } catch (const std::exception& e) {
      f.error = e.what();
    }
    apply(std::move(f));
  }

  /// Uploads a loaded frame (a frame still being written: its message, the last good frame stays).
  void apply(LoadedFrame&& f) {
    loaded_ = f.k;
    if (!f.error.empty()) {
      load_error_ = f.error;
      return;
    }
    current_ = std::move(f.particles);
    meshes_ = std::move(f.meshes);
    loaded_layers_ = f.layers;
    load_error_.clear();
    radius_ = f.radius;
    uploadParticles();
    for (auto& b : mesh_buffers_) b.destroy();
    mesh_buffers_.assign(meshes_.size(), VertexBuffer{});
    for (std::size_t i = 0; i < meshes_.size(); ++i) {
      mesh_buffers_[i].create(9);
      mesh_buffers_[i].upload(meshes_[i].vertices);
    }
  }

  /// Particle colours for the current mode (the range from this frame unless fixed), then upload.
  void uploadParticles() {
    const ParticleFrame& f = shown();
    // Automatic range: the 1st to 99th percentile of this frame, so that a few outliers (a
    // pressure spike at a wall) do not wash out the rest.
    if (colour_ != ColourBy::Phase && !fix_range_ && f.size() > 0) {
      std::vector<float> values(f.size());
      for (std::size_t i = 0; i < f.size(); ++i) values[i] = scalarOf(f, i, colour_);
      const std::size_t lo = values.size() / 100, hi = values.size() - 1 - values.size() / 100;
      std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(lo), values.end());
      range_[0] = values[lo];
      std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(hi), values.end());
      range_[1] = values[hi];
    }
    std::vector<float> data;
    data.reserve(f.size() * 6);
    const float span = std::max(range_[1] - range_[0], 1e-12f);
    for (std::size_t i = 0; i < f.size(); ++i) {
      const Eigen::Vector3f c = colour_ == ColourBy::Phase ? Eigen::Vector3f(f.r[i], f.g[i], f.b[i])
                                                           : viridis((scalarOf(f, i, colour_) - range_[0]) / span);
      data.insert(data.end(), {f.x[i], f.y[i], f.z[i], c.x(), c.y(), c.z()});
    }
    particles_.upload(data);
  }

  /// The domain box's twelve edges and its floor.
  void buildBox() {
    const auto [lo, hi] = bounds();
    std::vector<float> lines;
    auto corner = [&](int i) { return Eigen::Vector3f(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z()); };
    for (int a = 0; a < 8; ++a)
      for (int bit = 1; bit < 8; bit <<= 1)
        if (!(a & bit)) {
          const Eigen::Vector3f p = corner(a), q = corner(a | bit);
          lines.insert(lines.end(), {p.x(), p.y(), p.z(), 0, 0, 1, q.x(), q.y(), q.z(), 0, 0, 1});
        }
    box_.upload(lines);
    const float z = lo.z();
    floor_.upload({lo.x(), lo.y(), z, 0, 0, 1, hi.x(), lo.y(), z, 0, 0, 1, hi.x(), hi.y(), z, 0, 0, 1,
                   lo.x(), lo.y(), z, 0, 0, 1, hi.x(), hi.y(), z, 0, 0, 1, lo.x(), hi.y(), z, 0, 0, 1});
  }

  /// Clears and draws the 3D layers into the bound framebuffer.
  void drawScene(int w, int h) {
    glViewport(0, 0, w, h);
    // Neutral grey background (equal R, G, B), so that coloured pixels are the scene's.
    glClearColor(0.16f, 0.16f, 0.16f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    glEnable(GL_PROGRAM_POINT_SIZE);
    const Eigen::Matrix4f view = camera_.view();
    const Eigen::Matrix4f proj = camera_.projection(static_cast<float>(w) / static_cast<float>(std::max(h, 1)));

    // Meshes: floor, box, surfaces, bodies.
    glUseProgram(mesh_program_);
    glUniformMatrix4fv(glGetUniformLocation(mesh_program_, "view"), 1, GL_FALSE, view.data());
    glUniformMatrix4fv(glGetUniformLocation(mesh_program_, "projection"), 1, GL_FALSE, proj.data());
    const GLint colour_loc = glGetUniformLocation(mesh_program_, "colour"), lit_loc = glGetUniformLocation(mesh_program_, "lit");
    const GLint vcol_loc = glGetUniformLocation(mesh_program_, "vertex_colours");
    glUniform1f(vcol_loc, 0.0f);
    if (layers_.box) {
      glUniform1f(lit_loc, 0.0f);
      glUniform3f(colour_loc, 0.09f, 0.09f, 0.09f);
      glEnable(GL_POLYGON_OFFSET_FILL);
      glPolygonOffset(1.0f, 1.0f);  // the floor behind what rests on it
      glBindVertexArray(floor_.vao);
      glDrawArrays(GL_TRIANGLES, 0, floor_.count);
      glDisable(GL_POLYGON_OFFSET_FILL);
      glUniform3f(colour_loc, 0.5f, 0.5f, 0.5f);
      glBindVertexArray(box_.vao);
      glDrawArrays(GL_LINES, 0, box_.count);
    }
    glUniform1f(lit_loc, 1.0f);
    for (std::size_t i = 0; i < meshes_.size() && i < mesh_buffers_.size(); ++i) {
      if (meshes_[i].body ? !layers_.bodies : !layers_.surfaces) continue;
      const Eigen::Vector3f& c = meshes_[i].colour;
      glUniform3f(colour_loc, c.x(), c.y(), c.z());
      glUniform1f(vcol_loc, meshes_[i].vertex_colours ? 1.0f : 0.0f);
      glBindVertexArray(mesh_buffers_[i].vao);
      glDrawArrays(GL_TRIANGLES, 0, mesh_buffers_[i].count);
    }
    glUniform1f(vcol_loc, 0.0f);

    // Particles as sphere sprites.
    if (layers_.particles && particles_.count > 0) {
      glUseProgram(point_program_);
      glUniformMatrix4fv(glGetUniformLocation(point_program_, "view"), 1, GL_FALSE, view.data());
      glUniformMatrix4fv(glGetUniformLocation(point_program_, "projection"), 1, GL_FALSE, proj.data());
      glUniform1f(glGetUniformLocation(point_program_, "radius"), radius_ * point_scale_);
      glUniform1f(glGetUniformLocation(point_program_, "viewport_h"), static_cast<float>(h));
      glBindVertexArray(particles_.vao);
      glDrawArrays(GL_POINTS, 0, particles_.count);
    }

    // Live: the device overlay on top of everything (the cursor may be inside the water).
    if (live_ && live_scene_ && live_scene_->haptics && overlay_points_.count > 0) {
      glDisable(GL_DEPTH_TEST);
      const Eigen::Vector3f ext = live_scene_->domain_max - live_scene_->domain_min;
      glUseProgram(point_program_);
      glUniform1f(glGetUniformLocation(point_program_, "radius"), std::max(2.0f * radius_, 0.008f * ext.norm()));
      glBindVertexArray(overlay_points_.vao);
      glDrawArrays(GL_POINTS, 0, overlay_points_.count);
      glUseProgram(mesh_program_);
      glUniform1f(lit_loc, 0.0f);
      glBindVertexArray(overlay_lines_.vao);
      glUniform3f(colour_loc, 0.2f, 0.9f, 0.9f);  // the spring: cursor to grasp point
      glDrawArrays(GL_LINES, 0, std::min(overlay_spring_, overlay_lines_.count));
      glUniform3f(colour_loc, 1.0f, 0.8f, 0.1f);  // the force sent to the device
      if (overlay_lines_.count > overlay_spring_) glDrawArrays(GL_LINES, overlay_spring_, overlay_lines_.count - overlay_spring_);
      glEnable(GL_DEPTH_TEST);
    }
    glBindVertexArray(0);
    glUseProgram(0);
  }

  /// Colour bar with the range, for the scalar colour modes.
  void drawLegend() {
    if (colour_ == ColourBy::Phase || !layers_.particles) return;
    const ImVec2 size(260, 62);
    ImGui::SetNextWindowPos(ImVec2(ImGui::GetIO().DisplaySize.x - size.x - 10, ImGui::GetIO().DisplaySize.y - size.y - 10));
    ImGui::SetNextWindowSize(size);
    ImGui::Begin("legend", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoInputs | ImGuiWindowFlags_NoSavedSettings);
    ImGui::TextUnformatted(kColourLabels[static_cast<int>(colour_)]);
    ImDrawList* dl = ImGui::GetWindowDrawList();
    const ImVec2 p = ImGui::GetCursorScreenPos();
    const float bar_w = size.x - 20, bar_h = 12;
    for (int s = 0; s < 32; ++s) {
      // Back to sRGB for ImGui, which draws colours as given.
      auto col = [&](float t) {
        const Eigen::Vector3f c = viridis(t);
        return ImGui::GetColorU32(ImVec4(std::pow(c.x(), 1 / 2.2f), std::pow(c.y(), 1 / 2.2f), std::pow(c.z(), 1 / 2.2f), 1));
      };
      const float x0 = p.x + bar_w * s / 32.0f, x1 = p.x + bar_w * (s + 1) / 32.0f;
      dl->AddRectFilledMultiColor(ImVec2(x0, p.y), ImVec2(x1, p.y + bar_h), col(s / 32.0f), col((s + 1) / 32.0f),
                                  col((s + 1) / 32.0f), col(s / 32.0f));
    }
    ImGui::Dummy(ImVec2(bar_w, bar_h));
    ImGui::Text("%.4g", range_[0]);
    char hi[32];
    std::snprintf(hi, sizeof hi, "%.4g", range_[1]);
    ImGui::SameLine(bar_w - ImGui::CalcTextSize(hi).x + 8);
    ImGui::TextUnformatted(hi);
    ImGui::End();
  }

  /// The control panel: playback, colour, layers, camera, help.
  void drawPanel() {
    ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
    ImGui::SetNextWindowSize(ImVec2(330, 0), ImGuiCond_FirstUseEver);
    ImGui::Begin("sphaptics view");
    const int n = run_->frames();
    ImGui::TextWrapped("%s", opt_.dir.c_str());
    ImGui::Text("status: %s   frames: %d", run_->info().status.empty() ? "(no run.json)" : run_->info().status.c_str(), n);
    ImGui::Text("frame %d   t = %.4f s   %zu particles", frame_, current_.time, current_.size());
    if (!load_error_.empty()) ImGui::TextWrapped("cannot read this frame yet: %s", load_error_.c_str());

    // Playback.
    if (ImGui::Button("|<")) frame_ = 0;
    ImGui::SameLine();
    if (ImGui::Button("<")) frame_ = std::max(frame_ - 1, 0);
    ImGui::SameLine();
    if (ImGui::Button(playing_ ? "pause" : "play")) playing_ = !playing_;
    ImGui::SameLine();
    if (ImGui::Button(">")) frame_ = std::min(frame_ + 1, std::max(n - 1, 0));
    ImGui::SameLine();
    if (ImGui::Button(">|")) frame_ = std::max(n - 1, 0);
    ImGui::SameLine();
    ImGui::Checkbox("loop", &loop_);
    ImGui::SliderInt("frame", &frame_, 0, std::max(n - 1, 0));
    float fps = static_cast<float>(playbackRate());
    if (ImGui::SliderFloat("frames/s", &fps, 1.0f, 240.0f, "%.0f", ImGuiSliderFlags_Logarithmic)) fps_ = fps;
    if (run_->running()) ImGui::Checkbox("follow the newest frame", &follow_);

    // Colour.
    int mode = static_cast<int>(colour_);
    if (ImGui::Combo("colour", &mode, kColourLabels, 4)) {
      colour_ = static_cast<ColourBy>(mode);
      fix_range_ = false;
      uploadParticles();
    }
    if (colour_ != ColourBy::Phase) {
      if (ImGui::Checkbox("fix range", &fix_range_) && !fix_range_) uploadParticles();
      if (fix_range_ && ImGui::InputFloat2("range", range_)) uploadParticles();
    }
    ImGui::SliderFloat("particle size", &point_scale_, 0.2f, 3.0f, "%.2f x");

    // Layers.
    ImGui::Checkbox("particles (1)", &layers_.particles);
    ImGui::SameLine();
    ImGui::Checkbox("surfaces (2)", &layers_.surfaces);
    ImGui::Checkbox("bodies (3)", &layers_.bodies);
    ImGui::SameLine();
    ImGui::Checkbox("box (4)", &layers_.box);
    if (ImGui::Button("frame the domain (F)")) resetCamera();
    ImGui::Text("viewer: %.0f frames/s", static_cast<double>(ImGui::GetIO().Framerate));
    if (ImGui::CollapsingHeader("mouse and keys"))
      ImGui::TextUnformatted("left drag: orbit   right / middle drag: pan\nwheel: zoom   space: play / pause\n"
                             "left / right: step   home / end: first / last\n1-4: layers   C: colour   F: frame   Q / Esc: quit");
    ImGui::End();
  }

  void resetCamera() {
    int w = 0, h = 0;
    glfwGetFramebufferSize(window_, &w, &h);
    const auto [lo, hi] = bounds();
    const float fovy = camera_.fovy;
    camera_ = OrbitCamera{};
    camera_.fovy = fovy;
    camera_.frame(lo, hi, static_cast<float>(w) / static_cast<float>(std::max(h, 1)));
  }

  /// Mouse (orbit, pan, zoom) and keys, unless the panel has them.
  void handleInput(int height) {
    const ImGuiIO& io = ImGui::GetIO();
    double x = 0, y = 0;
    glfwGetCursorPos(window_, &x, &y);
    const float dx = static_cast<float>(x - mouse_[0]), dy = static_cast<float>(y - mouse_[1]);
    mouse_[0] = x;
    mouse_[1] = y;
    if (mouse_in_) {
      // The mouse is the haptic device: left = grab, wheel = depth of the cursor's plane;
      // right drag orbits, middle drag pans, shift + wheel zooms.
      const bool left = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
      if (!io.WantCaptureMouse || grab_down_) {
        if (glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) camera_.orbit(dx, dy);
        if (glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS) camera_.pan(dx, dy, static_cast<float>(height));
        const bool shift = glfwGetKey(window_, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS || glfwGetKey(window_, GLFW_KEY_RIGHT_SHIFT) == GLFW_PRESS;
        sendCamera(false);
        if (dx != 0 || dy != 0) {
          haptics::MouseEvent ev;
          ev.kind = haptics::MouseEvent::Kind::Move;
          ev.x = x;
          ev.y = y;
          mouse_in_->push(ev);
        }
        if (scroll_ != 0) {
          if (shift) {
            camera_.zoom(scroll_);
          } else {
            haptics::MouseEvent ev;
            ev.kind = haptics::MouseEvent::Kind::Wheel;
            ev.steps = -scroll_;  // wheel up (positive) brings the plane nearer
            mouse_in_->push(ev);
          }
        }
        if (left != grab_down_) {
          haptics::MouseEvent ev;
          ev.kind = haptics::MouseEvent::Kind::Button;
          ev.pressed = left;
          mouse_in_->push(ev);
          grab_down_ = left;
        }
      }
    } else if (!io.WantCaptureMouse) {
      if (glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) camera_.orbit(dx, dy);
      if (glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS ||
          glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS)
        camera_.pan(dx, dy, static_cast<float>(height));
      camera_.zoom(scroll_);
    }
    scroll_ = 0;
    if (io.WantCaptureKeyboard) return;
    if (live_) {  // live keys: no timeline
      if (ImGui::IsKeyPressed(GLFW_KEY_P) || ImGui::IsKeyPressed(GLFW_KEY_SPACE)) {
        paused_ = !paused_;
        live_->controls.paused = paused_;
      }
      if (ImGui::IsKeyPressed(GLFW_KEY_R)) requestReset();
      if (ImGui::IsKeyPressed(GLFW_KEY_1)) layers_.particles = !layers_.particles;
      if (ImGui::IsKeyPressed(GLFW_KEY_3)) layers_.bodies = !layers_.bodies;
      if (ImGui::IsKeyPressed(GLFW_KEY_4)) layers_.box = !layers_.box;
      if (ImGui::IsKeyPressed(GLFW_KEY_F)) resetCamera();
      if (ImGui::IsKeyPressed(GLFW_KEY_C)) {
        colour_ = static_cast<ColourBy>((static_cast<int>(colour_) + 1) % 4);
        fix_range_ = false;
        if (live_frame_) uploadParticles();
      }
      if (ImGui::IsKeyPressed(GLFW_KEY_Q) || ImGui::IsKeyPressed(GLFW_KEY_ESCAPE)) glfwSetWindowShouldClose(window_, 1);
      return;
    }
    // ImGui 1.86 indexes keys by the GLFW key codes.
    const int n = run_->frames();
    if (ImGui::IsKeyPressed(GLFW_KEY_SPACE)) playing_ = !playing_;
    if (ImGui::IsKeyPressed(GLFW_KEY_RIGHT)) frame_ = std::min(frame_ + 1, std::max(n - 1, 0));
    if (ImGui::IsKeyPressed(GLFW_KEY_LEFT)) frame_ = std::max(frame_ - 1, 0);
    if (ImGui::IsKeyPressed(GLFW_KEY_HOME)) frame_ = 0;
    if (ImGui::IsKeyPressed(GLFW_KEY_END)) frame_ = std::max(n - 1, 0);
    if (ImGui::IsKeyPressed(GLFW_KEY_1)) layers_.particles = !layers_.particles;
    if (ImGui::IsKeyPressed(GLFW_KEY_2)) layers_.surfaces = !layers_.surfaces;
    if (ImGui::IsKeyPressed(GLFW_KEY_3)) layers_.bodies = !layers_.bodies;
    if (ImGui::IsKeyPressed(GLFW_KEY_4)) layers_.box = !layers_.box;
    if (ImGui::IsKeyPressed(GLFW_KEY_F)) resetCamera();
    if (ImGui::IsKeyPressed(GLFW_KEY_C)) {
      colour_ = static_cast<ColourBy>((static_cast<int>(colour_) + 1) % 4);
      fix_range_ = false;
      uploadParticles();
    }
    if (ImGui::IsKeyPressed(GLFW_KEY_Q) || ImGui::IsKeyPressed(GLFW_KEY_ESCAPE)) glfwSetWindowShouldClose(window_, 1);
  }

  const ViewOptions& opt_;
  RunData* run_ = nullptr;                       ///< playback: the folder (null when live)
  std::shared_ptr<LiveLink> live_;               ///< live: the running simulation's link (null in playback)
  std::shared_ptr<haptics::MouseInput> mouse_in_;  ///< live with the mouse backend: its input queue
  std::shared_ptr<const LiveScene> live_scene_;
  std::shared_ptr<const LiveFrame> live_frame_;  ///< the frame on screen (kept while it is drawn)
  VertexBuffer overlay_points_, overlay_lines_;  ///< device cursor and grasp point; spring and force arrow
  int overlay_spring_ = 0;                       ///< vertices of the spring line in overlay_lines_
  float arrow_scale_ = 0.1f;                     ///< force arrow length per newton (unit: m/N)
  // Live statistics: per new frame (window clock, frame, simulated time, servo ticks, servo clock, |F|).
  struct Sample {
    double wall, time, servo_seconds, force;
    int frame;
    uint64_t ticks;
  };
  std::deque<Sample> samples_;
  long samples_total_ = 0;  ///< simulation frames taken from the mailbox
  float gain_ = 1.0f;
  int smoothing_ = 0;  ///< rolling-average window (unit: frames), 0 = the servo's smoothing
  bool paused_ = false, settings_read_ = false;
  bool grab_down_ = false;
  double last_camera_[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  GLFWwindow* window_ = nullptr;
  bool glfw_ = false, imgui_ = false;
  GLuint point_program_ = 0, mesh_program_ = 0, fbo_ = 0, rbo_[2] = {0, 0};
  VertexBuffer particles_, box_, floor_;
  std::vector<VertexBuffer> mesh_buffers_;
  OrbitCamera camera_;
  Layers layers_;
  ColourBy colour_ = ColourBy::Phase;
  float range_[2] = {0, 1};
  bool fix_range_ = false;
  float point_scale_ = 1.0f;
  float radius_ = 0.005f;
  int frame_ = 0, loaded_ = -1;
  long shown_ = 0;  ///< frames loaded and uploaded by the playback loop
  double shown_rate_ = 0;  ///< ... per second of the last loop (unit: 1/s)

 public:
  double shownRate() const { return shown_rate_; }

 private:
  std::array<bool, 2> loaded_layers_{false, false};  ///< surfaces, bodies read for the loaded frame
  bool playing_ = false, loop_ = true, follow_ = true;
  double fps_ = 0;
  double mouse_[2] = {0, 0};
  float scroll_ = 0;
  bool input_seen_ = false;  ///< an input event since the last live redraw
  ParticleFrame current_;
  std::vector<LoadedMesh> meshes_;
  std::string load_error_;
};

}  // namespace

int viewCommand(const ViewOptions& opt) {
  // Bad input first (exit 2): the folder, its run.json, the frame.
  int first = 0;
  std::unique_ptr<RunData> run;
  try {
    if (!fs::is_directory(opt.dir)) throw InputError(opt.dir, 0, 0, "no such output folder");
    run = std::make_unique<RunData>(opt.dir);
    if (run->frames() == 0 && !run->running())
      throw InputError(opt.dir, 0, 0, "nothing to show: no particles.h5part(.partial) and no fluid_*/body_* OBJ files");
    if (!(opt.particle_size > 0 && opt.particle_size <= 10))
      throw InputError("--particle-size", 0, 0, "must be above 0 and at most 10");
    if (opt.width < 16 || opt.height < 16 || opt.width > 8192 || opt.height > 8192)
      throw InputError("--size", 0, 0, "width and height must be 16 to 8192 pixels");
    const int n = run->frames();
    if (opt.frame == "last") {
      first = std::max(n - 1, 0);
    } else {
      std::size_t used = 0;
      try {
        first = std::stoi(opt.frame, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != opt.frame.size() || first < 0) throw InputError("--frame", 0, 0, "'" + opt.frame + "' is not a frame index or 'last'");
      if (first >= n && !(n == 0 && first == 0))
        throw InputError("--frame", 0, 0, "frame " + opt.frame + " is not in the run (frames 0 to " + std::to_string(n - 1) + ")");
    }
  } catch (const InputError& e) {
    std::cerr << e.what() << "\n";
    return kExitBadInput;
  }

  try {
    Viewer viewer(opt, run.get());
    viewer.open(/*visible=*/opt.screenshot.empty());
    if (!opt.screenshot.empty()) {
      viewer.screenshot(first, opt.screenshot);
      std::cout << "wrote " << opt.screenshot << " (frame " << first << ", " << opt.width << " x " << opt.height << ")\n";
      return kExitOk;
    }
    const double fps = viewer.loop(first);
    if (opt.benchmark > 0)
      std::cout << "viewer: " << fps << " frames/s over " << opt.benchmark << " s, " << viewer.shownRate()
                << " run frames loaded per second\n";
    return kExitOk;
  } catch (const WindowError& e) {
    std::cerr << "view: " << e.what() << "\n";
    return kExitDevice;
  } catch (const InputError& e) {
    std::cerr << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "view: " << e.what() << "\n";
    return kExitDevice;
  }
}

int liveWindow(const LiveViewOptions& opt, std::shared_ptr<LiveLink> link, std::shared_ptr<haptics::MouseInput> mouse,
               const std::function<bool()>& run_done) {
  ViewOptions vo;
  vo.dir = opt.title;
  vo.width = opt.width;
  vo.height = opt.height;
  vo.colour = opt.colour;
  try {
    // The scene is set before the first frame; wait for it (the run is compiling the scene).
    while (!link->mailbox.scene() && !run_done()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (!link->mailbox.scene()) return kExitOk;
    Viewer viewer(vo, nullptr, link, std::move(mouse));
    viewer.open(/*visible=*/true);
    const double fps = viewer.liveLoop(run_done, opt.screenshot);
    if (!opt.screenshot.empty()) std::cout << "wrote " << opt.screenshot << "\n";
    std::cout << "window: " << fps << " pictures/s drawn (only for a new frame or input), " << viewer.shownRate()
              << " simulation frames/s shown\n";
    return kExitOk;
  } catch (const std::exception& e) {
    std::cerr << "window: " << e.what() << "; going on without it\n";
    return kExitDevice;
  }
}

}  // namespace sph::viewer
