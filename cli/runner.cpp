#include "cli/runner.h"

#include "cli/haptics_setup.h"

#include "core/errors.h"
#include "haptics/command_reader.h"
#include "io/bodies_writer.h"
#include "io/cloth_writer.h"
#include "io/async_writer.h"
#include "io/h5part_writer.h"
#include "io/probes_writer.h"
#include "io/obj_io.h"
#include "io/surface_export.h"
#include "io/vdb_writer.h"
#include "io/run_json.h"
#include "io/run_lock.h"
#include "io/scene_loader.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;

namespace sph::app {

namespace {

// The signal that asked the run to stop (SIGINT, SIGTERM or SIGHUP), 0 while none did. Each is
// handled like Ctrl-C: the frame loop ends, the output is closed and run.json says "interrupted".
std::atomic<int> g_stop_signal{0};
extern "C" void onStopSignal(int sig) { g_stop_signal = sig; }

/// Installs the stop handlers for the frame loop; restores the old ones at scope exit.
class StopSignals {
 public:
  StopSignals() {
    g_stop_signal = 0;
    for (std::size_t i = 0; i < 3; ++i) old_[i] = std::signal(kSignals[i], onStopSignal);
  }
  ~StopSignals() {
    for (std::size_t i = 0; i < 3; ++i) std::signal(kSignals[i], old_[i]);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  static constexpr int kSignals[3] = {SIGINT, SIGTERM, SIGHUP};
  void (*old_[3])(int) = {};
};

/// Ignores SIGPIPE while in scope (a closed stdout/stderr pipe, e.g. `| head`: the write fails
/// with EPIPE and the run goes on, instead of dying silently with run.json left "running").
class IgnoreSigpipe {
 public:
  IgnoreSigpipe() : old_(std::signal(SIGPIPE, SIG_IGN)) {}
  ~IgnoreSigpipe() { std::signal(SIGPIPE, old_); }
  IgnoreSigpipe(const IgnoreSigpipe&) = delete;
  IgnoreSigpipe& operator=(const IgnoreSigpipe&) = delete;

 private:
  void (*old_)(int);
};

const char* signalName(int sig) {
  switch (sig) {
    case SIGINT: return "SIGINT (Ctrl-C)";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    default: return "a signal";
  }
}

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// particles.h5part: after the fluid, every rigid body's boundary particles (type rigid, at the
// body's pose, with its point velocity and colour) and every cloth node (type cloth, the cloth's
// colour). Their phase is -1, density and pressure 0; ids continue past the fluid's largest (body
// particles in body order, then the nodes), so they are stable over a run.
void appendSolids(ParticleFrame& f, const Model& model, Simulation& sim) {
  int64_t next = 0;
  for (int64_t id : f.id) next = std::max(next, id + 1);
  next = std::max<int64_t>(next, static_cast<int64_t>(model.capacity));
  if (f.type.empty()) f.type.assign(f.size(), kFluid);
  auto push = [&](const Eigen::Vector3d& x, const Eigen::Vector3d& v, const Eigen::Vector3d& c, int32_t type) {
    f.x.push_back(float(x.x())), f.y.push_back(float(x.y())), f.z.push_back(float(x.z()));
    f.vx.push_back(float(v.x())), f.vy.push_back(float(v.y())), f.vz.push_back(float(v.z()));
    f.density.push_back(0.0f), f.pressure.push_back(0.0f), f.phase.push_back(-1), f.id.push_back(next++);
    f.r.push_back(float(c.x())), f.g.push_back(float(c.y())), f.b.push_back(float(c.z()));
    f.type.push_back(type);
  };
  for (std::size_t b = 0; b < model.bodies.size(); ++b) {
    const rigid::BodyState& s = sim.bodies()[b];
    for (const Eigen::Vector3f& p : model.bodies[b].particles) {
      const Eigen::Vector3d r = s.q * p.cast<double>();
      push(s.x + r, s.v + s.w.cross(r), model.bodies[b].spec.colour, kRigid);
    }
  }
  if (sim.cloth()) {
    std::vector<Eigen::Vector4f> x, v;
    sim.cloth()->read(x, v);
    for (std::size_t k = 0; k < x.size(); ++k)
    {
      // Cloth nodes (type cloth), then soft-body nodes (type soft), each in its item's colour.
      const std::size_t item = model.cloth.cloth_of[k];
      const bool soft = model.cloth.isSoft(item);
      push(x[k].head<3>().cast<double>(), v[k].head<3>().cast<double>(),
           soft ? model.spec.soft_bodies[item - model.cloth.num_cloths].colour : model.spec.cloth[item].colour,
           soft ? kSoft : kCloth);
    }
  }
}

std::string humanRate(double v) {
  char buf[32];
  if (v >= 1e6) std::snprintf(buf, sizeof buf, "%.2f M", v / 1e6);
  else if (v >= 1e3) std::snprintf(buf, sizeof buf, "%.1f k", v / 1e3);
  else std::snprintf(buf, sizeof buf, "%.0f ", v);
  return buf;
}

std::string profileLine(const Profile& p) {
  std::ostringstream s;
  const double total = p.total();
  s << "profile:";
  for (int i = 0; i < kNumStages; ++i) {
    const double t = p.seconds[static_cast<std::size_t>(i)];
    if (t <= 0) continue;
    char buf[64];
    std::snprintf(buf, sizeof buf, " %s %.2fs (%.0f%%, %.2f ms/step)", stageName(static_cast<Stage>(i)), t,
                  total > 0 ? 100.0 * t / total : 0.0, p.steps ? 1e3 * t / static_cast<double>(p.steps) : 0.0);
    s << buf;
  }
  if (p.rigid_reduce_seconds > 0 && p.steps > 0) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "; of rigid_coupling, the per-body reduction %.3fs (%.3f ms/step)", p.rigid_reduce_seconds,
                  1e3 * p.rigid_reduce_seconds / static_cast<double>(p.steps));
    s << buf;
  }
  s << "; neighbour lists built " << p.grid_builds << " times in " << p.steps << " steps";
  if (p.subdivided_frames) s << "; CFL subdivided " << p.subdivided_frames << " frame(s)";
  if (p.cfl_warned_frames) s << "; ran " << p.cfl_warned_frames << " frame(s) above the CFL limit";
  if (p.density_iterations > 0 && p.steps > 0) {  // solver dfsph
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "; DFSPH: %.2f density and %.2f divergence iterations per step, largest average density error "
                  "%.3g %%, divergence %.3g %%, %llu step(s) above the bound",
                  double(p.density_iterations) / double(p.steps), double(p.divergence_iterations) / double(p.steps),
                  100.0 * p.max_density_error, 100.0 * p.max_divergence_error,
                  static_cast<unsigned long long>(p.unconverged_steps));
    s << buf;
    // The implicit viscosity's conjugate gradients (fluid.dfsph.viscosity_solve: implicit)
    if (p.viscosity_iterations > 0) {
      std::snprintf(buf, sizeof buf, "; implicit viscosity: %.2f CG iterations per step, largest residual %.3g, %llu step(s) "
                    "at its most iterations", double(p.viscosity_iterations) / double(p.steps), p.max_viscosity_residual,
                    static_cast<unsigned long long>(p.viscosity_unconverged_steps));
      s << buf;
    }
    // The two-level solve's coarse-grid corrections (fluid.dfsph.coarse_interval > 0)
    if (p.density_corrections + p.divergence_corrections > 0) {
      std::snprintf(buf, sizeof buf, "; %.2f density and %.2f divergence coarse corrections per step",
                    double(p.density_corrections) / double(p.steps), double(p.divergence_corrections) / double(p.steps));
      s << buf;
      if (p.corrections_reused > 0)
        s << " (" << p.corrections_reused << " with a reused operator, fluid.dfsph.coarse_reuse)";
      if (p.corrections_stopped > 0)
        s << " (" << p.corrections_stopped << " solve(s) stopped correcting: a correction did not lower the error)";
    }
    // What set the steps' length (Simulation::dfsphStepLimit)
    s << "; steps set by";
    for (int l = 0; l < kNumStepLimiters; ++l)
      s << (l ? ", " : " ") << stepLimiterName(static_cast<StepLimiter>(l)) << " "
        << p.dfsph_step_limiters[static_cast<std::size_t>(l)];
    // The steps against the pressure's own scale (docs/dfsph.md, session 15)
    std::snprintf(buf, sizeof buf, "; largest dt sqrt(max p / rho) / dx %.2f", p.max_pressure_step_ratio);
    s << buf;
    if (p.steps_over_pressure_scale > 0)
      s << " (" << p.steps_over_pressure_scale << " step(s) over 1, where a column at rest can bounce: "
        << "fluid.dfsph.pressure_cfl bounds them)";
  }
  return s.str();
}

// --profile-kernels: each kernel's wall time per step and dispatches per step, largest first.
std::string kernelProfileLine(const char* title, const std::map<std::string, double>& seconds,
                              const std::map<std::string, uint64_t>& counts, uint64_t steps) {
  std::vector<std::pair<double, std::string>> order;
  double total = 0;
  for (const auto& [name, t] : seconds) order.emplace_back(t, name), total += t;
  std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  const double per = 1.0 / static_cast<double>(std::max<uint64_t>(steps, 1));
  std::ostringstream s;
  char buf[160];
  std::snprintf(buf, sizeof buf, "%s: total %.2f", title, 1e3 * total * per);
  s << buf;
  for (const auto& [t, name] : order) {
    const auto c = counts.find(name);
    std::snprintf(buf, sizeof buf, "; %s %.2f (%.2f)", name.c_str(), 1e3 * t * per,
                  c == counts.end() ? 0.0 : static_cast<double>(c->second) * per);
    s << buf;
  }
  return s.str();
}

}  // namespace

namespace {

// fluid_%04d.vdb: grid "density" = the sum of the phases' fields (what Blender's volume material
// reads), plus "density_<phase>" per phase when there are several, and the level set "surface"
// of the total field on request. All grids share the surface grid's transform.
void writeSurfaceVdb(const fs::path& dir, int frame, const std::vector<PhaseSpec>& phases,
                     const std::vector<DenseGrid>& fields, const IsosurfaceSpec& iso) {
  DenseGrid total = fields.front();
  for (std::size_t ph = 1; ph < fields.size(); ++ph)
    for (std::size_t k = 0; k < total.values.size(); ++k) total.values[k] += fields[ph].values[k];
  std::vector<io::NamedGrid> grids{{"density", &total}};
  if (fields.size() > 1)
    for (std::size_t ph = 0; ph < fields.size() && ph < phases.size(); ++ph)
      grids.push_back({io::surfaceVdbGridName(phases[ph].name), &fields[ph]});
  io::VdbOptions opt;
  opt.level_set = iso.vdb_level_set;
  opt.iso = static_cast<float>(iso.iso);
  io::writeVdb((dir / io::surfaceVdbName(frame)).string(), grids, opt);
}

}  // namespace

RunResult runScene(const RunOptions& opt, const std::function<void(Simulation&, const FrameReport&)>& on_frame) {
  RunResult res;
  IgnoreSigpipe ignore_sigpipe;  // a closed stdout/stderr pipe must not kill the run
  const bool tty = !opt.quiet && isatty(fileno(stderr));
  auto log = [&](const std::string& line) {
    if (!opt.quiet) std::cerr << line << "\n";
  };

  // Output state, so that a failure can mark the run as failed.
  std::unique_ptr<io::H5PartWriter> h5;
  std::unique_ptr<io::BodiesCsvWriter> bodies_csv;
  std::unique_ptr<io::ClothCsvWriter> cloth_csv, soft_csv;
  std::unique_ptr<io::StepForcesCsvWriter> forces_csv;
  std::unique_ptr<io::ProbesCsvWriter> probes_csv;
  std::unique_ptr<std::ofstream> haptics_csv;
  std::unique_ptr<io::AsyncWriter> writer;  // after h5: destroyed (joined) before it
  fs::path out_dir, h5_partial, h5_final;
  bool h5_written = false;  // this run created h5_partial
  io::RunLock lock;         // the output folder's lock, held from before anything in it is touched
  io::RunWarnings warnings;
  io::RunInfo info;
  Clock::time_point t_start = Clock::now();

  std::function<RunResult(int, const std::string&, const std::string&)> finish;
  finish = [&](int code, const std::string& status, const std::string& message) {
    res.exit_code = code;
    res.message = message;
    if (writer) {  // finish the frames already handed over (each file is written whole)
      const std::string err = writer->close();
      res.writer_seconds = writer->busySeconds();
      if (!err.empty() && code == kExitOk) {
        std::cerr << "error: writing output failed: " << err << "\n";
        return finish(1, "failed", "writing output failed: " + err);
      }
    }
    if (h5) h5->close();
    if (bodies_csv) bodies_csv->close();
    if (cloth_csv) cloth_csv->close();
    if (soft_csv) soft_csv->close();
    if (forces_csv) forces_csv->close();
    if (probes_csv) probes_csv->close();
    if (haptics_csv) haptics_csv->close();
    if (!out_dir.empty() && opt.write_output) {
      info.status = status;
      info.message = message;
      info.frames = res.frames;
      info.sim_time = res.sim_time;
      info.wall_seconds = since(t_start);
      info.particles = res.particles;
      info.profile = res.profile;
      info.isosurface_seconds = res.iso_seconds;
      info.output_seconds = res.output_seconds;
      info.writer_seconds = res.writer_seconds;
      info.warnings = warnings;
      // Only a complete run gets the final file name; anything else keeps ".partial". Only the
      // file this run wrote is renamed: never another run's .partial found in the folder.
      std::error_code ec;
      if (status == "complete" && h5_written && fs::exists(h5_partial)) fs::rename(h5_partial, h5_final, ec);
      try {
        io::writeRunJson((out_dir / "run.json").string(), info);
      } catch (const std::exception& e) {
        std::cerr << "error: " << e.what() << "\n";
        if (res.exit_code == kExitOk) res.exit_code = 1;
      }
    }
    lock.release();
    return res;
  };

  try {
    // --- Scene: load, override, compile --------------------------------------------------
    SceneSpec spec = io::loadScene(opt.scene, opt.sets);
    // --duration: a finite time > 0 (-1, nan and inf are refused, never read as "the scene's").
    if (opt.duration_given || opt.duration >= 0.0) {
      if (!(opt.duration > 0.0) || !std::isfinite(opt.duration))
        throw InputError("--duration", 0, 0, "must be > 0 and finite (unit: s), got " + std::to_string(opt.duration));
      spec.simulation.duration = opt.duration;
    }
    // A run simulates whole frames: round(duration x frame_rate) of them. Less than half a frame
    // is refused (--duration here, the scene's key in compile()); a duration that is not a whole
    // number of frames is said, never silently changed.
    {
      const double fps = spec.simulation.frame_rate;
      const double exact = spec.simulation.duration * fps;
      const bool given = opt.duration_given || opt.duration >= 0.0;
      const std::string what = given ? "--duration" : "simulation.duration";
      if (given && !(exact < 1e9))
        throw InputError(what, 0, 0, "is " + std::to_string(exact) + " frames at " + std::to_string(fps) +
                                         " fps: more than 1e9 frames");
      if (given && std::lround(exact) < 1)
        throw InputError(what, 0, 0, "is shorter than half a frame (" + std::to_string(spec.simulation.duration) +
                                         " s; 1 / frame_rate = " + std::to_string(1.0 / fps) +
                                         " s): a run simulates whole frames");
      if (exact < 1e9 && std::abs(exact - std::round(exact)) > 1e-6 * std::max(1.0, exact)) {
        std::ostringstream s;
        s << what << " " << spec.simulation.duration << " s is not a whole number of frames at " << fps
          << " fps: simulating " << std::lround(exact) << " frame(s) = " << std::lround(exact) / fps << " s";
        log("note: " + s.str());
        info.notes.push_back(s.str());
      }
    }
    ResourceLimits limits;
    limits.max_bytes = opt.max_memory;
    Compiled compiled = compile(spec, limits);
    const Model& model = compiled.model;
    for (const std::string& note : model.notes) log("note: " + note);
    for (const std::string& w : model.warnings) log("warning: " + w);

    // Isosurface: only when the scene asks for it (output.isosurface).
    const IsosurfaceSpec& iso = spec.output.isosurface;
    IsoSettings iso_settings;
    iso_settings.spacing = iso.spacing > 0 ? iso.spacing : kAutoIsoSpacingRatio * model.dx;
    iso_settings.iso = static_cast<float>(iso.iso);
    iso_settings.vertex_colours = iso.vertex_colours;
    iso_settings.meshes = iso.obj;  // a VDB-only export needs the field, not the meshes

    // --- Output folder: locked before the device starts (a busy folder is refused at once,
    // having touched nothing but the lock) ---------------------------------------------------
    // From here on a stop signal ends the run through finish() (run.json, lock released); before,
    // nothing was touched and the default action (exit) is right.
    StopSignals stop_signals;
    fs::path dir;
    if (opt.write_output) {
      if (!opt.out.empty()) dir = opt.out;
      else if (!spec.output.directory.empty()) dir = spec.output.directory;
      else dir = fs::path("out") / fs::path(opt.scene).stem();
      std::error_code ec;
      fs::create_directories(dir, ec);
      if (ec || !fs::is_directory(dir))
        throw InputError(dir.string(), 0, 0, "cannot create the output folder: " + (ec ? ec.message() : "not a folder"));
      // One run per folder: take the lock before anything in the folder is touched (a busy
      // folder is refused here, exit 2, naming the run that holds it).
      if (const std::string note = lock.acquire(dir.string()); !note.empty()) {
        log("note: " + note);
        info.notes.push_back(note);
      }
    }

    // --- Device and simulation -----------------------------------------------------------
    ClContext cl(opt.device);
    log("OpenCL " + cl.info().str());
    Simulation sim(model, compiled.initial, cl);
    sim.setInterrupt(&g_stop_signal);  // a signal stops the run within a step, not at a frame's end
    sim.profileKernels(opt.profile_kernels);
    for (const std::string& name : opt.disable) {
      auto st = stageFromName(name);
      if (!st) throw InputError("--disable", 0, 0, "unknown stage '" + name + "' (stages: " + stageNameList() + ")");
      if (!sim.disable(*st)) throw InputError("--disable", 0, 0, "stage '" + name + "' cannot be disabled");
    }

    // --- Output folder: nothing from an earlier run may look like this run's result (only once
    // the device is up and the options are good: a run that fails before leaves the folder as it was)
    if (opt.write_output) {
      std::error_code ec;
      out_dir = dir;  // from here on, failures are recorded in run.json
      h5_final = out_dir / "particles.h5part";
      h5_partial = out_dir / "particles.h5part.partial";
      fs::remove(h5_final, ec);
      fs::remove(out_dir / "run.json", ec);
      fs::remove(out_dir / "bodies.csv", ec);
      fs::remove(out_dir / "forces.csv", ec);
      fs::remove(out_dir / "probes.csv", ec);
      fs::remove(out_dir / "haptics.csv", ec);
      fs::remove(out_dir / "cloth.csv", ec);
      fs::remove(out_dir / "soft.csv", ec);
      for (const auto& entry : fs::directory_iterator(out_dir, ec)) {  // an earlier run's meshes
        const std::string name = entry.path().filename().string();
        const auto ext = entry.path().extension();
        if ((name.rfind("fluid_", 0) == 0 && (ext == ".obj" || ext == ".vdb")) ||
            (name.rfind("body_", 0) == 0 && ext == ".obj") || (name.rfind("cloth_", 0) == 0 && ext == ".obj") ||
            (name.rfind("soft_", 0) == 0 && ext == ".obj"))
          fs::remove(entry.path(), ec);
      }
    }
    log("stages: " + sim.stages().str());
    // Haptics: only a scene with a `haptics` section (and a body to hold) gets a session; in batch
    // runs the servo runs in virtual time between steps (haptics/session.h), no thread.
    std::unique_ptr<haptics::BatchSession> haptic;
    std::unique_ptr<haptics::LiveSource> live;  // --interactive: the servo thread (here or in a bridge), real time
    std::unique_ptr<haptics::ReplaySource> replay;  // sphaptics replay: recorded readings, hashes checked
    haptics::Recording recording;                    // --record
    if (opt.interactive && !sim.stages().on(Stage::Haptics))
      throw InputError("--interactive", 0, 0, "needs a scene with a 'haptics' section and a dynamic body");
    if (opt.mouse && !sim.stages().on(Stage::Haptics))
      throw InputError("--mouse", 0, 0, "needs a scene with a 'haptics' section and a grabbable dynamic body");
    if (!opt.record.empty() && !opt.interactive) throw InputError("--record", 0, 0, "records a live run: add --interactive");
    if (!opt.record.empty()) {  // refused now, not after the run; the probe leaves no empty file behind
      const bool existed = fs::exists(opt.record);
      const bool writable = static_cast<bool>(std::ofstream(opt.record, std::ios::app));
      const int err = errno;
      std::error_code ec;
      if (!existed) fs::remove(opt.record, ec);
      if (!writable) throw InputError("--record", 0, 0, "cannot write '" + opt.record + "': " + std::strerror(err));
    }
    if (opt.replay && !sim.stages().on(Stage::Haptics))
      throw InputError(opt.scene, 0, 0, "the recorded scene has no 'haptics' section (or no dynamic body) any more");
    if (!opt.interactive && !opt.replay && sim.stages().on(Stage::Haptics) && spec.haptics.backend == HapticBackend::Bridge)
      throw InputError(spec.source_file, spec.haptics.loc.line, spec.haptics.loc.col,
                       "'haptics.backend: bridge' talks to a running sphaptics-bridge in real time: run with --interactive");
    if (opt.replay) {
      replay = makeReplaySource(model, *opt.replay);
      sim.setExternalForces(replay.get());
      res.haptics = true;
    } else if (opt.interactive) {
      live = makeLiveSession(model, opt.mouse);
      sim.setExternalForces(live.get());
      res.haptics = true;
    } else if (sim.stages().on(Stage::Haptics)) {
      haptic = makeBatchSession(model, opt.mouse);
      sim.setExternalForces(haptic.get());
      haptic->publish(sim.time(), sim.bodies());
      res.haptics = true;
    }
    {
      std::ostringstream s;
      s << "scene: " << compiled.initial.size() << " fluid particles (budget " << model.capacity << "), "
        << model.boundary.size() << " boundary particles, " << model.bodies.size() << " rigid bodies, dx = " << model.dx << " m, h = " << model.h
        << " m, c0 = " << model.c0 << " m/s, " << model.num_frames << " frames at " << spec.simulation.frame_rate
        << " fps";
      log(s.str());
    }

    // --- Output: run.json says "running", the writers open ---------------------------------
    if (opt.write_output) {
      info.scene_file = spec.source_file;
      // the resolved scene: with fluid.dfsph.viscosity_solve's `auto` as the model resolved it (core/model.cpp)
      SceneSpec resolved = spec;
      resolved.fluid.dfsph.viscosity_solve = model.spec.fluid.dfsph.viscosity_solve;
      info.scene_json = io::sceneToJson(resolved);
      info.device = cl.info().str();
      info.stages = sim.stages().str();
      info.notes.insert(info.notes.end(), model.notes.begin(), model.notes.end());
      info.status = "running";
      io::writeRunJson((out_dir / "run.json").string(), info);
      if (spec.output.particles) {
        h5 = std::make_unique<io::H5PartWriter>(h5_partial.string());
        h5_written = true;
      }
      if (!model.bodies.empty()) bodies_csv = std::make_unique<io::BodiesCsvWriter>((out_dir / "bodies.csv").string());
      if (!model.spec.cloth.empty() && model.cloth.nodes() > 0)
        cloth_csv = std::make_unique<io::ClothCsvWriter>((out_dir / "cloth.csv").string());
      if (!model.spec.soft_bodies.empty())
        soft_csv = std::make_unique<io::ClothCsvWriter>((out_dir / "soft.csv").string(), true);
      if (spec.output.step_forces && !model.bodies.empty()) {
        forces_csv = std::make_unique<io::StepForcesCsvWriter>((out_dir / "forces.csv").string());
        sim.recordStepForces(true);
      }
      if (sim.stages().on(Stage::Probes)) {
        probes_csv = std::make_unique<io::ProbesCsvWriter>((out_dir / "probes.csv").string(), spec.probes);
        sim.recordProbeSamples(true);
      }
      if (haptic || live) {
        haptics_csv = std::make_unique<std::ofstream>(out_dir / "haptics.csv", std::ios::trunc);
        if (!*haptics_csv)
          throw std::runtime_error("cannot write " + (out_dir / "haptics.csv").string() + ": " + std::strerror(errno));
        *haptics_csv << haptics::hapticsCsvHeader();
      }
      writer = std::make_unique<io::AsyncWriter>(3);
      res.out_dir = out_dir.string();
    }

    // --- Frames ---------------------------------------------------------------------------
    // Per output frame: read back what is exported (the device work happens here), then hand the
    // files to the writer thread, which formats and writes them while the simulation goes on.
    const bool write_obj = writer && iso.enabled && iso.obj;
    const bool write_vdb = writer && iso.enabled && (iso.vdb || iso.vdb_level_set);
    auto write_frame = [&](int frame, bool timed) {
      std::shared_ptr<std::vector<TriMesh>> meshes;
      if (iso.enabled) {
        const auto t0 = Clock::now();
        meshes = std::make_shared<std::vector<TriMesh>>(sim.surfaceMeshes(iso_settings));
        if (timed) res.iso_seconds += since(t0);
        res.surface_vertices = res.surface_triangles = 0;
        for (const TriMesh& m : *meshes) {
          res.surface_vertices += m.numVertices();
          res.surface_triangles += m.numTriangles();
        }
      }
      const auto t0 = Clock::now();
      if (bodies_csv) {  // a few rows and small meshes: written here, in order
        bodies_csv->writeFrame(sim.time(), model.bodies, sim.bodies());
        io::writeBodyObjs(out_dir.string(), frame, model.bodies, sim.bodies());
      }
      if (forces_csv) forces_csv->write(sim.takeStepForces(), model.bodies);
      if (cloth_csv || soft_csv) {  // cloths and soft bodies: a row and a mesh each (broken springs left out)
        std::vector<Eigen::Vector4f> x, v;
        sim.cloth()->read(x, v);
        const std::vector<uint32_t> broken = sim.cloth()->readBroken();
        const Eigen::Vector3d g = gravityAt(model.spec.simulation, sim.time());
        for (std::size_t c = 0; cloth_csv && c < model.spec.cloth.size(); ++c) {
          const ClothSpec& cs = model.spec.cloth[c];
          cloth_csv->writeRow(sim.time(), cs.name, sim.cloth()->report(c, g));
          io::writeObj((out_dir / io::clothObjName(cs.name, frame)).string(), io::clothMesh(model.cloth, c, cs, x, broken));
        }
        for (std::size_t b = 0; soft_csv && b < model.spec.soft_bodies.size(); ++b) {
          const SoftBodySpec& sb = model.spec.soft_bodies[b];
          soft_csv->writeRow(sim.time(), sb.name, sim.cloth()->report(model.cloth.num_cloths + b, g));
          io::writeObj((out_dir / io::softObjName(sb.name, frame)).string(), io::softMesh(model.cloth, b, sb.colour, x, broken));
        }
      }
      if (probes_csv) probes_csv->write(sim.takeProbeSamples());
      if (!writer || (!h5 && !write_obj && !write_vdb)) {
        res.output_seconds += since(t0);
        return;
      }
      std::shared_ptr<ParticleFrame> particles;
      if (h5) {
        particles = std::make_shared<ParticleFrame>(sim.readFrame());
        appendSolids(*particles, model, sim);  // rigid-body particles and cloth nodes, with their type
      }
      if (!write_obj) meshes.reset();
      // The surface field of each phase (read back here; summed and written on the writer thread).
      std::shared_ptr<std::vector<DenseGrid>> fields;
      if (write_vdb) {
        fields = std::make_shared<std::vector<DenseGrid>>();
        for (std::size_t ph = 0; ph < spec.fluid.phases.size(); ++ph)
          fields->push_back(sim.surfaceField(static_cast<uint32_t>(ph)));
      }
      const double grid_spacing = sim.lastSurfaceGrid() ? sim.lastSurfaceGrid()->spacing : iso_settings.spacing;
      io::SurfaceObjInfo header;
      header.particle_spacing = model.dx;
      header.time = sim.time();
      header.frame = frame;
      header.iso = iso.iso;
      header.grid_spacing = grid_spacing;
      const std::vector<PhaseSpec>& phases = spec.fluid.phases;
      io::H5PartWriter* h5_raw = h5.get();
      const fs::path dir = out_dir;
      writer->push([=] {
        if (particles) h5_raw->writeStep(*particles);
        if (meshes)
          for (std::size_t ph = 0; ph < meshes->size() && ph < phases.size(); ++ph) {
            io::SurfaceObjInfo info = header;
            info.phase = phases[ph].name;
            for (int a = 0; a < 3; ++a) info.colour[a] = static_cast<float>(phases[ph].colour[a]);
            io::writeObj((dir / io::surfaceObjName(info.phase, frame)).string(), (*meshes)[ph],
                         io::surfaceObjComment(info));
          }
        if (fields && !fields->empty() && !fields->front().values.empty()) writeSurfaceVdb(dir, frame, phases, *fields, iso);
      });
      res.output_seconds += since(t0);
      if (const std::string err = writer->error(); !err.empty()) throw std::runtime_error("writing output failed: " + err);
    };
    // --- Live window (RunOptions::live_link): the scene once, then each frame's particles, body
    // poses, cloth meshes and device, swapped into the mailbox (the simulation never waits for it).
    Eigen::Vector3d last_force = Eigen::Vector3d::Zero();  // batch: the last servo tick's force (unit: N)
    const haptics::Mapping mapping = res.haptics ? hapticMapping(spec) : haptics::Mapping{};
    if (opt.live_link) {
      auto scene = std::make_shared<LiveScene>();
      scene->title = opt.scene;
      scene->domain_min = model.spec.domain.min.cast<float>();  // the walls on the lattice (core/model.cpp)
      scene->domain_max = model.spec.domain.max.cast<float>();
      scene->particle_radius = static_cast<float>(0.5 * model.dx);
      scene->frame_rate = spec.simulation.frame_rate;
      for (const rigid::RigidBody& b : model.bodies) {
        scene->body_names.push_back(b.spec.name);
        scene->body_meshes.push_back(b.mesh);
        scene->body_colours.push_back(b.spec.colour.cast<float>());
      }
      for (const ClothSpec& c : spec.cloth) scene->cloth_colours.push_back(c.colour.cast<float>());
      for (const SoftBodySpec& b : spec.soft_bodies) scene->cloth_colours.push_back(b.colour.cast<float>());  // drawn like cloths
      scene->haptics = res.haptics;
      opt.live_link->mailbox.setScene(scene);
    }
    auto publish_live = [&](int frame, bool finished) {
      if (!opt.live_link) return;
      auto lf = std::make_shared<LiveFrame>();
      lf->frame = frame;
      lf->time = sim.time();
      lf->wall = since(t_start);
      lf->finished = finished;
      lf->particles = sim.readFrame();
      for (const rigid::BodyState& b : sim.bodies()) {
        lf->body_positions.push_back(b.x.cast<float>());
        lf->body_orientations.push_back(b.q.cast<float>());
      }
      if (sim.cloth() && model.cloth.nodes() > 0) {
        std::vector<Eigen::Vector4f> x, v;
        sim.cloth()->read(x, v);
        const std::vector<uint32_t> broken = sim.cloth()->readBroken();
        for (std::size_t c = 0; c < spec.cloth.size(); ++c)
          lf->cloths.push_back(io::clothMesh(model.cloth, c, spec.cloth[c], x, broken));
        for (std::size_t b = 0; b < spec.soft_bodies.size(); ++b)
          lf->cloths.push_back(io::softMesh(model.cloth, b, spec.soft_bodies[b].colour, x, broken));
      }
      // The device: cursor and grasp point from the grab, the force in scene axes (the arrow).
      const haptics::GrabController* grab = live ? &live->grab() : haptic ? &haptic->grab() : nullptr;
      if (grab) {
        LiveHaptics& h = lf->haptics;
        h.cursor = grab->target();
        h.held = grab->grabbed();
        h.grasp = grab->graspWorld(sim.bodies());
        h.gain = grab->gain();
        if (live) {
          const haptics::LiveStats st = live->stats();
          const haptics::LiveSettings set = live->controls().settings();
          h.force = mapping.rotation * st.force;
          h.servo_ticks = st.ticks;
          h.servo_seconds = lf->wall;
          h.smoothing = set.smoothing == haptics::Smoothing::RollingAverage ? set.rolling_window : 0;
        } else {
          const haptics::ServoConfig& c = haptic->servo().config();
          h.force = mapping.rotation * last_force;
          h.servo_ticks = res.haptic_ticks;
          h.servo_seconds = sim.time();
          h.smoothing = c.smoothing == haptics::Smoothing::RollingAverage ? c.rolling_window : 0;
        }
      }
      opt.live_link->mailbox.publish(std::move(lf));
    };
    // The loop's wall time and the simulation's profile into the result and run.json: at the end, or
    // where a numerical failure ends the run.
    auto take_profile = [&] {
      res.loop_seconds = since(t_start);
      res.wall_seconds = res.loop_seconds - res.output_seconds - res.iso_seconds;
      res.profile = sim.profile();
      info.particle_steps_per_second = sim.profile().particle_steps / std::max(res.wall_seconds, 1e-9);
    };
    // The settle before t = 0 (simulation.settle_time): frame 0 is the settled state.
    bool settle_interrupted = false;
    if (spec.simulation.settle_time > 0.0 && sim.numFluid() > 0) {
      std::ostringstream s;
      s << "settling: the fluid comes to rest under gravity for " << spec.simulation.settle_time
        << " s before t = 0 (bodies and cloth held)";
      log(s.str());
      try {
        sim.settle();
        s.str("");
        s << "settled: " << sim.profile().settle_steps << " steps in " << std::fixed << std::setprecision(1)
          << sim.profile().settle_seconds << " s; largest speed in its last step " << std::setprecision(3)
          << std::scientific << sim.profile().settle_max_speed << " m/s (then set to 0)";
        log(s.str());
      } catch (const Interrupted&) {
        settle_interrupted = true;  // a signal during the settle: no frame is written, the loop below stops at once
      }
    }
    if (!settle_interrupted) write_frame(0, false);  // Step#0 / fluid_*_0000.obj: the initial state
    res.output_seconds = 0;
    t_start = Clock::now();
    double last_log = 0.0;
    const int frames = opt.replay ? opt.replay->frames
                                  : std::max(1, static_cast<int>(std::lround(spec.simulation.duration * spec.simulation.frame_rate)));
    // Live: the controls (stdin commands when it is a terminal or a pipe, the viewer's panel via
    // live->controls()) are applied at frame boundaries; the servo's ticks go to haptics.csv.
    std::unique_ptr<haptics::CommandReader> commands;
    // The controls handed to opt.live_controls are taken back however the run ends (this guard
    // goes before `live` does).
    bool controls_handed = false;
    struct TakeBack {
      const RunOptions& opt;
      bool& handed;
      ~TakeBack() {
        if (handed) opt.live_controls(nullptr);
        handed = false;
      }
    } take_back{opt, controls_handed};
    double paused_seconds = 0.0;  // wall time spent paused (the pacing skips it)
    auto apply_controls = [&](int frame) {
      haptics::LiveSettings s;
      if (live && live->applyControls(sim.time(), s) && !opt.record.empty()) recording.settings.emplace_back(frame, s);
      if (replay)
        for (const auto& [at, st] : opt.replay->settings)
          if (at == frame) replay->applySettings(st);
    };
    auto drain_ticks = [&]() {  // the servo's ticks since the last call: haptics.csv and --record
      if (!live) return;
      const std::vector<haptics::TickRecord> ticks = live->takeTicks();
      std::vector<haptics::HapticsRow> rows;
      rows.reserve(ticks.size());
      for (const haptics::TickRecord& t : ticks) {
        if (t.servo) rows.push_back(t.row);
        if (!opt.record.empty()) recording.ticks.emplace_back(t.tick, t.reading);
      }
      if (haptics_csv) {
        errno = 0;
        haptics::writeHapticsRows(*haptics_csv, rows);
        haptics_csv->flush();
        if (!*haptics_csv)
          throw std::runtime_error("cannot write " + (out_dir / "haptics.csv").string() + ": " + std::strerror(errno ? errno : EIO));
      }
    };
    if (live) {
      live->record(!opt.record.empty());
      apply_controls(0);
      live->publish(sim.bodies());
      live->start();
      log("live: device " + live->deviceName());
      if (opt.live_controls) {
        opt.live_controls(&live->controls());
        controls_handed = true;
      }
      if (haptics::CommandReader::wanted(STDIN_FILENO)) {
        commands = std::make_unique<haptics::CommandReader>(live->controls(), STDIN_FILENO, [&opt](const std::string& line) {
          if (!opt.quiet) std::cerr << line << "\n";
        });
        log("live: commands on stdin: gain G, scale S, offset X Y Z, smoothing servo | rolling_average N, pause, resume, quit "
            "(any of them after 'at T')");
      }
    } else if (replay) {
      apply_controls(0);
    }
    double last_live_log = 0.0;
    uint64_t last_live_ticks = 0;
    int last_live_frames = 0;
    publish_live(0, false);
    for (int f = 0; f < frames; ++f) {
      if (g_stop_signal) break;
      if (opt.live_link) {  // the window's requests: stop, reset, pause and settings
        WindowRequests& c = opt.live_link->requests;
        if (c.stop.load() || c.reset.load()) {
          res.stopped_by_window = true;
          break;
        }
        if (live) {
          // Live: through the session's controls (haptics/live.h), applied at this frame boundary.
          if (c.paused.load() != live->controls().settings().paused) live->controls().setPaused(c.paused.load());
          if (const double g = c.gain.exchange(std::numeric_limits<double>::quiet_NaN()); std::isfinite(g) && g >= 0)
            live->controls().setGain(g);
          if (const double n = c.smoothing.exchange(std::numeric_limits<double>::quiet_NaN()); std::isfinite(n) && n >= 0)
            live->controls().setSmoothing(n >= 1 ? haptics::Smoothing::RollingAverage : haptics::Smoothing::Servo,
                                          std::max(1, static_cast<int>(std::lround(n))));
        } else {
          // Batch under a window: pause here (not counted in the pacing); the gain on the grab.
          if (c.paused.load()) {
            const auto p0 = Clock::now();
            while (c.paused.load() && !c.stop.load() && !c.reset.load() && !g_stop_signal)
              std::this_thread::sleep_for(std::chrono::milliseconds(10));
            t_start += Clock::now() - p0;
          }
          if (c.stop.load() || c.reset.load()) {
            res.stopped_by_window = true;
            break;
          }
          if (const double g = c.gain.exchange(std::numeric_limits<double>::quiet_NaN()); std::isfinite(g) && g >= 0 && haptic)
            haptic->grab().setGain(g);
        }
      }
      if (live) {
        // quit ends the run as complete; pause holds the simulation (the servo keeps rendering the
        // last model, refreshed so that the watchdog does not fade it), bounded by the stop signal.
        if (live->controls().quitRequested()) break;
        const auto pause_start = Clock::now();
        while (live->controls().settings().paused && !live->controls().quitRequested() && !g_stop_signal) {
          live->check();
          live->publish(sim.bodies());
          drain_ticks();
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        paused_seconds += since(pause_start);
        if (live->controls().quitRequested() || g_stop_signal) break;
        live->check();  // a device that stopped answering: exit 3
      }
      FrameReport rep;
      try {
        rep = sim.advanceFrame();
      } catch (const Interrupted&) {
        break;  // a signal in the middle of a frame: reported below as interrupted, as between frames
      } catch (const NumericalError&) {
        // A run that fails keeps what its per-step files recorded in the failed frame, up to the
        // failure (forces.csv, probes.csv): the steps that lead into a blow-up are the ones to read.
        if (forces_csv) forces_csv->write(sim.takeStepForces(), model.bodies);
        if (probes_csv) probes_csv->write(sim.takeProbeSamples());
        take_profile();  // and run.json says how far it got: the steps and the profile up to the failure
        throw;
      }
      if (live && !opt.record.empty()) {  // --record: the ticks this frame's steps used, and its hash
        const auto used = live->takeStepTicks();
        recording.step_ticks.insert(recording.step_ticks.end(), used.begin(), used.end());
        const auto step_hashes = live->takeStepHashes();
        recording.step_hashes.insert(recording.step_hashes.end(), step_hashes.begin(), step_hashes.end());
        recording.hashes.push_back(sim.stateHash());
      }
      if (replay) {  // replay: every step's body hash and every frame's whole-state hash as recorded
        if (replay->firstDifferingStep() > 0)
          throw std::runtime_error("replay: the bodies' state hash differs from the recording at step " +
                                   std::to_string(replay->firstDifferingStep()) + " (in frame " + std::to_string(f + 1) + ")");
        const uint64_t h = sim.stateHash();
        const std::size_t k = static_cast<std::size_t>(f);
        if (k >= opt.replay->hashes.size() || h != opt.replay->hashes[k])
          throw std::runtime_error("replay: the state hash differs from the recording at frame " + std::to_string(f + 1));
        ++res.replay_frames_checked;
      }
      if (live) {  // live: the frame's local model; frames no faster than real time; a status line a second
        live->publish(sim.bodies());
        drain_ticks();
        apply_controls(f + 1);
        std::this_thread::sleep_until(t_start + std::chrono::duration_cast<Clock::duration>(
                                                    std::chrono::duration<double>(sim.time() + paused_seconds)));
        const double wall = since(t_start);
        if (wall - last_live_log >= 1.0 || f + 1 == frames) {
          const haptics::LiveStats st = live->stats();
          char buf[256];
          std::snprintf(buf, sizeof buf, "live t=%.2f s: sim %.1f frames/s, servo %.0f Hz, overruns %llu, |F| = %.3f N",
                        sim.time(), (f + 1 - last_live_frames) / std::max(wall - last_live_log, 1e-9),
                        static_cast<double>(st.ticks - last_live_ticks) / std::max(wall - last_live_log, 1e-9),
                        static_cast<unsigned long long>(st.overruns), st.force.norm());
          if (!opt.quiet) std::cerr << buf << "\n";
          last_live_log = wall;
          last_live_ticks = st.ticks;
          last_live_frames = f + 1;
        }
      } else if (replay) {
        apply_controls(f + 1);
      }
      if (haptic) {  // the frame's local model to the servo; the ticks so far to haptics.csv
        haptic->publish(sim.time(), sim.bodies());
        const auto rows = haptic->takeRows();
        res.haptic_ticks += rows.size();
        if (!rows.empty()) last_force = rows.back().force;
        if (haptics_csv) {
          errno = 0;  // so that a failed write names its own reason
          haptics::writeHapticsRows(*haptics_csv, rows);
          haptics_csv->flush();
          if (!*haptics_csv)
            throw std::runtime_error("cannot write " + (out_dir / "haptics.csv").string() + ": " +
                                     std::strerror(errno ? errno : EIO));
        }
      }
      for (const std::string& m : rep.messages) log((tty ? "\n" : "") + std::string("note: ") + m);
      // Warnings: what a user must act on (NaN/inf, a time step above the CFL limit, particles
      // moving more than h in a step) is printed the first time it happens, also under --quiet;
      // everything (wall crossings too) is counted, summarised at the end and kept in run.json.
      {
        const io::RunWarnings before = warnings;
        warnings.add(rep);
        std::ostringstream s;
        const char* sep = "";
        if (rep.nonfinite && !before.nonfinite) s << sep << rep.nonfinite << " particle(s) with NaN/inf", sep = "; ";
        if (io::RunWarnings::stepOverLimit(rep) && !before.cfl_step_frames)
          s << sep << "time step " << rep.dt << " s is " << rep.dt / rep.dt_limit << " x the CFL limit " << rep.dt_limit
            << " s (time_step_control: warn; raise simulation.substeps or use subdivide)",
              sep = "; ";
        if (rep.cfl_violations && !before.cfl_violations)
          s << sep << rep.cfl_violations << " particle(s) moved more than h in one step", sep = "; ";
        if (*sep)
          std::cerr << (tty ? "\n" : "") << "warning: frame " << rep.frame << " t=" << rep.time << " s: " << s.str()
                    << " (later frames are counted in the summary and run.json)\n";
      }
      res.reports.push_back(rep);
      res.frames = f + 1;
      res.sim_time = sim.time();
      res.particles = sim.numFluid();
      write_frame(f + 1, true);
      publish_live(f + 1, f + 1 == frames);
      if (on_frame) on_frame(sim, rep);

      // Progress: a live line on a terminal, a plain line every 10 s otherwise.
      const double wall = since(t_start);
      if (!opt.quiet && (tty || wall - last_log > 10.0 || f + 1 == frames)) {
        const double sim_wall = wall - res.output_seconds - res.iso_seconds;
        const double fps = res.frames / std::max(wall, 1e-9);
        const double pss = sim.profile().particle_steps / std::max(sim_wall, 1e-9);
        const double eta = (frames - res.frames) / std::max(fps, 1e-9);
        char buf[256];
        std::snprintf(buf, sizeof buf, "frame %d/%d  t=%.3f s  %.2f frames/s  %sparticle-steps/s  %zu particles  ETA %.0f s",
                      res.frames, frames, sim.time(), fps, humanRate(pss).c_str(), sim.numFluid(), eta);
        if (tty) std::cerr << "\r" << buf << "\033[K" << std::flush;
        else if (!tty && (wall - last_log > 10.0)) std::cerr << buf << "\n";
        if (!tty) last_log = wall;
      }
    }
    if (live) {
      commands.reset();
      if (controls_handed) opt.live_controls(nullptr);
      controls_handed = false;
      live->stop();
      drain_ticks();
      const haptics::LiveStats st = live->stats();
      res.haptic_ticks = st.ticks;
      res.servo_p99 = st.period_p99;
      res.servo_overruns = st.overruns;
      char buf[320];
      if (spec.haptics.backend == HapticBackend::Bridge)
        std::snprintf(buf, sizeof buf,
                      "live bridge: %llu States received (interval p50 %.3f ms, p99 %.3f ms, max %.3f ms), %llu rejected, "
                      "bridge servo %.0f Hz, %llu overruns; State age when a model is sent p50 %.1f ms",
                      static_cast<unsigned long long>(st.ticks), 1e3 * st.period_p50, 1e3 * st.period_p99, 1e3 * st.period_max,
                      static_cast<unsigned long long>(st.rejected), st.servo_rate, static_cast<unsigned long long>(st.overruns),
                      1e3 * st.round_trip);
      else
        std::snprintf(buf, sizeof buf, "live servo: %llu ticks, period p50 %.3f ms, p99 %.3f ms, max %.3f ms, %llu overruns%s",
                      static_cast<unsigned long long>(st.ticks), 1e3 * st.period_p50, 1e3 * st.period_p99, 1e3 * st.period_max,
                      static_cast<unsigned long long>(st.overruns), st.realtime ? " (real-time priority)" : " (no real-time priority)");
      log(buf);
      if (st.dropped) {
        const std::string note = std::to_string(st.dropped) + " servo tick record(s) dropped (the ring was full): haptics.csv "
                                 "and --record miss them";
        log("warning: " + note);
        info.notes.push_back(note);
      }
    }
    if (live && !opt.record.empty()) {  // the recording, for `sphaptics replay`
      recording.scene = spec.source_file;
      recording.sets = opt.sets;
      recording.frames = static_cast<int>(recording.hashes.size());
      haptics::writeRecording(opt.record, recording);
      log("recorded " + std::to_string(recording.ticks.size()) + " servo ticks, " + std::to_string(recording.step_ticks.size()) +
          " steps (each with its bodies' hash) and " + std::to_string(recording.frames) + " frame hashes to " + opt.record);
    }
    if (tty) std::cerr << "\n";
    take_profile();
    res.device_bytes = sim.deviceBytes();
    res.dispatch_counts = sim.dispatchCounts();
    res.kernel_seconds = sim.kernelSeconds();
    res.kernel_cpu_seconds = sim.kernelCpuSeconds();
    res.state_hash = sim.stateHash();

    if (res.stopped_by_window) {
      publish_live(res.frames, true);
      log("stopped from the window at frame " + std::to_string(res.frames));
      return finish(kExitOk, "interrupted", "stopped from the window at frame " + std::to_string(res.frames));
    }
    if (const int sig = g_stop_signal; sig != 0) {
      log(std::string("interrupted by ") + signalName(sig) + " at frame " + std::to_string(res.frames) +
          (h5_written ? ": output kept as particles.h5part.partial" : ""));
      return finish(128 + sig, "interrupted", std::string("interrupted by ") + signalName(sig));
    }
    // Summary: one line, then the per-stage profile.
    if (!opt.quiet) {
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "done: %d frames, %.3f s simulated in %.2f s wall (%.2f frames/s), %llu steps, %zu particles, "
                    "%sparticle-steps/s",
                    res.frames, res.sim_time, res.wall_seconds, res.frames / std::max(res.wall_seconds, 1e-9),
                    static_cast<unsigned long long>(res.profile.steps), res.particles,
                    humanRate(info.particle_steps_per_second).c_str());
      log(buf);
      log(profileLine(res.profile));
      if (opt.profile_kernels) {
        log(kernelProfileLine("kernels (wall ms/step, dispatches/step)", res.kernel_seconds, res.dispatch_counts, res.profile.steps));
        log(kernelProfileLine("kernels (process CPU ms/step, dispatches/step)", res.kernel_cpu_seconds, res.dispatch_counts,
                              res.profile.steps));
      }
      if (const std::string w = warnings.summary(); !w.empty()) log("warnings: " + w);
      if (spec.output.isosurface.enabled) {
        std::snprintf(buf, sizeof buf,
                      "isosurface: %.3f s per frame on the device (%.0f%% of the frame loop), last frame %zu vertices, "
                      "%zu triangles; output hand-off %.3f s per frame",
                      res.iso_seconds / std::max(res.frames, 1), 100.0 * res.iso_seconds / std::max(res.loop_seconds, 1e-9),
                      res.surface_vertices, res.surface_triangles, res.output_seconds / std::max(res.frames, 1));
        log(buf);
      }
      if (!out_dir.empty()) log("output: " + out_dir.string());
    }
    return finish(kExitOk, "complete", "");
  } catch (const InputError& e) {
    std::cerr << e.what() << "\n";
    return finish(kExitBadInput, "failed", e.what());
  } catch (const DeviceError& e) {
    std::cerr << (tty ? "\n" : "") << "device error: " << e.what() << "\n";
    return finish(kExitDevice, "failed", e.what());
  } catch (const haptics::DeviceError& e) {  // a haptic device that cannot open or stopped answering
    std::cerr << (tty ? "\n" : "") << "haptic device error: " << e.what() << "\n";
    return finish(kExitDevice, "failed", std::string("haptic device: ") + e.what());
  } catch (const haptics::RecordingError& e) {  // --record FILE cannot be written: bad input
    std::cerr << (tty ? "\n" : "") << "error: " << e.what() << "\n";
    return finish(kExitBadInput, "failed", e.what());
  } catch (const NumericalError& e) {
    std::cerr << (tty ? "\n" : "") << "error: " << e.what() << "\n";
    return finish(kExitNumerical, "failed", e.what());
  } catch (const std::exception& e) {
    std::cerr << (tty ? "\n" : "") << "error: " << e.what() << "\n";
    return finish(1, "failed", e.what());
  }
}

}  // namespace sph::app
