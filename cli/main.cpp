// sphaptics: command-line entry point. Parses the command line (CLI11) and dispatches to the
// commands in cli/; this is the only place where io/, core/ and the commands are wired together.
#include "cli/commands.h"
#include "cli/compare.h"
#include "cli/force_analysis.h"
#include "cli/runner.h"
#include "core/errors.h"
#include "viewer/view_options.h"

#include <CLI/CLI.hpp>

#include <atomic>
#include <cstdlib>
#include <iostream>
#include <thread>

namespace {

/// `run` with a window over it (viewer/): the simulation on a thread publishing frames, the window
/// on this one (GLFW wants the main thread). Reset ends the run and starts it again; closing the
/// window stops it. Without a window (no display) the run goes on headless.
int runWithWindow(sph::app::RunOptions run, bool mouse, const std::string& screenshot) {
  using namespace sph;
  auto link = std::make_shared<LiveLink>();
  run.live_link = link;
  if (mouse) run.mouse = std::make_shared<haptics::MouseInput>();
  std::atomic<bool> done{false};
  std::atomic<int> code{0};
  std::thread sim([&] {
    for (;;) {
      code = app::runScene(run).exit_code;
      if (!link->requests.reset.exchange(false) || link->requests.stop.load() || code.load() != 0) break;
      std::cerr << "reset: the scene starts again\n";
    }
    done = true;
  });
#ifdef SPHAPTICS_HAVE_VIEWER
  viewer::LiveViewOptions vo;
  vo.title = run.scene;
  vo.screenshot = screenshot;
  const int window = viewer::liveWindow(vo, link, run.mouse, [&] { return done.load(); });
  if (window == 0) link->requests.stop = true;  // the window was closed (or the run ended)
#else
  (void)screenshot;
  std::cerr << "window: this sphaptics was built without the viewer; going on without it\n";
#endif
  sim.join();
  return code.load();
}

}  // namespace

int main(int argc, char** argv) {
  using namespace sph;
  CLI::App app{"sphaptics: real-time SPH fluids, rigid bodies and cloth you can touch.\n"
               "Scenes are YAML files in SI units, Z up; see `sphaptics schema` for every key."};
  app.set_version_flag("--version", std::string("sphaptics ") + SPHAPTICS_VERSION);
  app.require_subcommand(1);

  // run
  app::RunOptions run;
  auto* cmd_run = app.add_subcommand("run", "Simulate a scene and write its output");
  cmd_run->add_option("scene", run.scene, "Scene file (YAML)")->required();
  cmd_run->add_option("--out,-o", run.out, "Output folder (default: the scene's output.directory, else out/<scene>)");
  cmd_run->add_option("--device,-d", run.device, "OpenCL device: cpu, gpu or an index from `sphaptics devices` "
                                                  "(default: $SPHAPTICS_DEVICE, else a GPU if any, else the CPU)");
  cmd_run->add_option("--set,-s", run.sets, "Override a scene key, e.g. --set fluid.particle_spacing=0.01")
      ->allow_extra_args(false);
  cmd_run->add_option("--disable", run.disable, "Switch off a stage (" + stageNameList() + ")")->allow_extra_args(false);
  auto* opt_duration = cmd_run->add_option("--duration", run.duration,
                                           "Simulated time in seconds (overrides simulation.duration; "
                                           "rounded to whole frames)");
  cmd_run->add_flag("--quiet,-q", run.quiet, "No progress line and no summary");
  cmd_run->add_flag("--profile-kernels", run.profile_kernels,
                    "Time every kernel (the queue is drained around each dispatch: slower, same results) and print "
                    "each kernel's ms per step after the profile line");
  const std::string max_memory_help =
      "Refuse scenes estimated to need more memory than this, e.g. 8G, 512M, 2GiB (default: the machine's memory)";
  std::string run_max_memory, validate_max_memory;
  cmd_run->add_option("--max-memory", run_max_memory, max_memory_help);
  cmd_run->add_option("--record", run.record,
                      "With --interactive: write the device reading of every step and a state hash per frame to FILE "
                      "(replay it with `sphaptics replay FILE`)");
  cmd_run->add_flag("--interactive", run.interactive,
                    "Live: the haptic servo on its own thread at its rate against the scene's device, frames paced to "
                    "real time; prints simulation rate, servo rate, overruns and force. Opens the live window when "
                    "there is a display and this build has the viewer (see --headless)");
  bool run_headless = false, run_window = false, run_mouse = false;
  std::string run_window_screenshot;
  cmd_run->add_flag("--headless", run_headless, "With --interactive: no window, even with a display");
  cmd_run->add_flag("--window", run_window,
                    "Open the live window over the run (also a batch run: frames as fast as the simulation goes)");
  cmd_run->add_flag("--mouse", run_mouse,
                    "The mouse is the haptic device (in the window: left button grabs, wheel sets the depth); "
                    "needs the window and a scene with a haptics section");
  cmd_run->add_option("--window-screenshot", run_window_screenshot,
                      "With the window: write its last picture (panel included) as a PNG when the run ends");

  // replay
  std::string replay_file;
  auto* cmd_replay = app.add_subcommand("replay", "Re-run a recorded live haptic session headless and check every state hash");
  cmd_replay->add_option("file", replay_file, "Recording written by `sphaptics run --interactive --record FILE`")->required();

  // validate
  std::vector<std::string> validate_files;
  auto* cmd_validate = app.add_subcommand("validate", "Check scene files and report every problem with file:line:col");
  cmd_validate->add_option("scenes", validate_files, "Scene files")->required();
  cmd_validate->add_option("--max-memory", validate_max_memory, max_memory_help);

  // schema, devices
  auto* cmd_schema = app.add_subcommand("schema", "List every scene key: type, default, unit, allowed values, doc");
  auto* cmd_devices = app.add_subcommand("devices", "List the OpenCL devices");

  // bench
  app::BenchOptions bench;
  auto* cmd_bench = app.add_subcommand("bench", "Speed and accuracy benchmarks (prints tables, writes CSV)");
  cmd_bench->add_option("--out,-o", bench.out, "Folder for the CSV files")->capture_default_str();
  cmd_bench->add_option("--device,-d", bench.device, "OpenCL device (as for run)");
  cmd_bench->add_option("--sizes", bench.sizes, "Particle counts for the speed table")->capture_default_str();
  cmd_bench->add_option("--substeps", bench.substeps, "Substep counts for the speed table")->capture_default_str();
  cmd_bench->add_option("--frames", bench.frames, "Frames per speed run")->capture_default_str();
  cmd_bench->add_option("--repeats", bench.repeats, "Runs per configuration (the median is reported)")
      ->capture_default_str();
  cmd_bench->add_flag("--speed-only", bench.speed_only,
                      "Skip the accuracy, impact and force tables (the isosurface and cloth tables run unless "
                      "--no-iso / --no-cloth)");
  cmd_bench->add_flag("--accuracy-only", bench.accuracy_only,
                      "Only the accuracy table (and the impact table unless --no-impact)");
  cmd_bench->add_option("--iso-sizes", bench.iso_sizes, "Particle counts for the isosurface table")
      ->capture_default_str();
  cmd_bench->add_flag("--iso-only", bench.iso_only, "Only the isosurface table (off / on / on + OBJ export)");
  cmd_bench->add_flag("!--no-iso", bench.iso, "Skip the isosurface table");
  cmd_bench->add_flag("--cloth-only", bench.cloth_only, "Only the cloth benches: the stability sweep (stiffness x step, xpbd and explicit) and the cost on balls_on_cloth (per stage, launches per step)");
  cmd_bench->add_flag("!--no-cloth", bench.cloth, "Skip the cloth stability sweep");
  cmd_bench->add_flag("--forces-only", bench.forces_only,
                      "Only the force checks of bodies in water (added mass, free vs held, Stokes drag and fall, sinking ball, drag at Re 20) against resolution");
  cmd_bench->add_flag("!--no-forces", bench.forces, "Skip the force checks");
  cmd_bench->add_option("--force-solvers", bench.force_solvers,
                        "fluid.solver values for the force checks (wcsph, dfsph; dfsph-ghost: dfsph with "
                        "fluid.boundary_velocity ghost; dfsph-strong: dfsph with fluid.dfsph.body_coupling strong, "
                        "the default; dfsph-staggered: with body_coupling staggered; a suffix -subtract or -keep, e.g. "
                        "wcsph-keep, dfsph-subtract: with that fluid.body_ambient_pressure)")
      ->check(CLI::IsMember({"wcsph", "wcsph-subtract", "wcsph-keep", "dfsph", "dfsph-subtract", "dfsph-keep",
                             "dfsph-ghost", "dfsph-strong", "dfsph-staggered"}))
      ->capture_default_str();
  cmd_bench->add_option("--force-checks", bench.force_checks,
                        "Only these groups of force checks (default: all): added-mass, free-held, release, stokes, "
                        "re20, sink, sink-fine, sink-rest, flush, fall, heave, long-tank")
      ->check(CLI::IsMember({"added-mass", "free-held", "release", "stokes", "re20", "sink", "sink-fine",
                             "sink-rest", "flush", "fall", "heave", "long-tank"}));
  cmd_bench->add_flag("!--no-long-tank", bench.force_long_tank,
                      "Skip the force checks' drag at Re 20 in the 80 cm tank (DFSPH; ~1 min at R/dx 3, ~13 min at 4)");
  cmd_bench->add_flag("--impact-only", bench.impact_only,
                      "Only the impact pressure on the far wall of the dam break (wcsph and dfsph)");
  cmd_bench->add_flag("!--no-impact", bench.impact, "Skip the impact pressure table");
  cmd_bench->add_option("--impact-size", bench.impact_size, "Particles of the impact pressure runs")
      ->check(CLI::Range(1000L, 10000000L))
      ->capture_default_str();
  cmd_bench->add_option("--accuracy-sizes", bench.accuracy_sizes, "Particle counts of the accuracy table's runs")
      ->check(CLI::Range(1000L, 10000000L))
      ->capture_default_str();
  cmd_bench->add_option("--accuracy-solvers", bench.accuracy_solvers,
                        "Solvers of the accuracy table: wcsph, dfsph (the scene's walls), dfsph-mirrored, dfsph-single, "
                        "dfsph-extrapolated")
      ->check(CLI::IsMember({"wcsph", "dfsph", "dfsph-mirrored", "dfsph-single", "dfsph-extrapolated"}))
      ->capture_default_str();
  cmd_bench->add_option("--accuracy-cfl", bench.accuracy_cfls,
                        "Courant numbers of the accuracy table (simulation.cfl, DFSPH's fluid.dfsph.cfl)")
      ->check(CLI::Range(0.01, 1.0))
      ->capture_default_str();
  cmd_bench->add_option("--accuracy-eos", bench.accuracy_eos, "WCSPH's equations of state in the accuracy table")
      ->check(CLI::IsMember({"linear", "tait"}))
      ->capture_default_str();
  cmd_bench->add_option("--accuracy-set", bench.accuracy_sets,
                        "Scene override for every accuracy run, after the bench's own (as run --set), e.g. "
                        "--accuracy-set fluid.dfsph.density_error=1e-4");
  cmd_bench->add_option("--accuracy-until", bench.accuracy_until,
                        "End of the accuracy runs in T = t sqrt(2 g / a) (3.6 covers the data to Z ~ 4; less scores "
                        "fewer points)")
      ->check(CLI::Range(0.5, 10.0))
      ->capture_default_str();

  // compare
  app::CompareOptions compare;
  auto* cmd_compare = app.add_subcommand("compare", "Compare two OBJ sequences (folders) or OBJ files frame by frame; "
                                                    "exit 0 within tolerance, 1 outside, 2 unreadable input");
  cmd_compare->add_option("a", compare.a, "Reference: an OBJ file or a folder of OBJ files")->required();
  cmd_compare->add_option("b", compare.b, "Candidate: an OBJ file or a folder (files matched by name)")->required();
  cmd_compare->add_option("--hausdorff", compare.hausdorff, "Symmetric Hausdorff distance tolerance (unit: particle spacings)")
      ->capture_default_str();
  cmd_compare->add_option("--volume", compare.volume,
                          "Enclosed-volume difference / mean surface area tolerance (unit: particle spacings)")
      ->capture_default_str();
  cmd_compare->add_option("--area", compare.area, "Relative surface-area difference tolerance (unit: 1)")
      ->capture_default_str();
  cmd_compare->add_option("--spacing", compare.spacing,
                          "Particle spacing (unit: m; default: the 'particle_spacing:' line of the OBJ header)");
  cmd_compare->add_flag("--quiet,-q", compare.quiet, "Print only the summary line");

  // forces
  app::ForcesOptions forces;
  auto* cmd_forces = app.add_subcommand("forces", "Smoothness of a body's fluid force for haptics, from forces.csv "
                                                  "(output.step_forces): mean drag, noise, content above the servo's low-pass");
  cmd_forces->add_option("file", forces.file, "forces.csv of a run with output.step_forces: true")->required();
  cmd_forces->add_option("--body", forces.body, "Body name (default: the first in the file)");
  cmd_forces->add_option("--from", forces.from, "Window start (unit: s)");
  cmd_forces->add_option("--to", forces.to, "Window end (unit: s)");
  cmd_forces->add_option("--cutoff", forces.cutoff, "Servo low-pass cut-off, one pole (unit: Hz)")->capture_default_str();
  cmd_forces->add_flag("--torque", forces.torque, "Analyse the torque against the angular velocity (a turning body) instead of the drag");
  cmd_forces->add_option("--frame-rate", forces.frame_rate,
                         "Also report the noise of per-frame samples at this rate, as bodies.csv sees it (unit: 1/s)");

  // view (the desktop viewer; see viewer/ and README "Viewer")
  viewer::ViewOptions view;
  auto* cmd_view = app.add_subcommand("view", "Play back an output folder (finished or still being written) in a window, "
                                              "or write one frame as a PNG with --screenshot");
  cmd_view->add_option("run_dir", view.dir, "Output folder of a run")->required();
  cmd_view->add_option("--screenshot", view.screenshot, "Write this frame as a PNG file and exit (no window shown)");
  cmd_view->add_option("--frame", view.frame, "Frame to show first or to screenshot: an index from 0, or 'last'")
      ->capture_default_str();
  cmd_view->add_option("--width", view.width, "Window / screenshot width (unit: pixels)")->capture_default_str();
  cmd_view->add_option("--height", view.height, "Window / screenshot height (unit: pixels)")->capture_default_str();
  cmd_view->add_option("--colour", view.colour, "Particle colour: phase, pressure, speed or density")
      ->check(CLI::IsMember(viewer::viewColourNames()))
      ->capture_default_str();
  cmd_view->add_option("--hide", view.hide, "Layer to switch off: particles, surfaces, bodies, box (repeatable)")
      ->check(CLI::IsMember(viewer::viewLayerNames()))
      ->allow_extra_args(false);
  cmd_view->add_option("--particle-size", view.particle_size,
                       "Particle sprite size, relative to half the particle spacing")->capture_default_str();
  cmd_view->add_option("--fps", view.fps, "Playback rate (unit: frames/s; default: the run's frame rate, real time)");
  cmd_view->add_option("--benchmark", view.benchmark,
                       "Play for this long, print the viewer's drawn frames per second, exit (unit: s)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitBadInput;
  }

  // --max-memory: a size with a unit; anything else is bad input.
  auto maxMemory = [](const std::string& text, double& bytes) {
    if (text.empty()) return true;
    bytes = app::parseBytes(text);
    if (bytes > 0) return true;
    std::cerr << "--max-memory: '" << text << "' is not a size (e.g. 8G, 512M, 2GiB)\n";
    return false;
  };
  if (*cmd_run) {
    run.duration_given = opt_duration->count() > 0;
    if (!maxMemory(run_max_memory, run.max_memory)) return kExitBadInput;
    if (run_headless && run_window) {
      std::cerr << "--headless: cannot be combined with --window\n";
      return kExitBadInput;
    }
    const char* display = std::getenv("DISPLAY");
    const bool have_display = display && *display;
    const bool window = run_window || (run.interactive && !run_headless && have_display);
    if (run_mouse && !window) {
      std::cerr << "--mouse: needs the window (--window, or --interactive with a display and without --headless)\n";
      return kExitBadInput;
    }
    if (!run_window_screenshot.empty() && !window) {
      std::cerr << "--window-screenshot: needs the window (--window, or --interactive with a display)\n";
      return kExitBadInput;
    }
    if (window) return runWithWindow(run, run_mouse, run_window_screenshot);
    return app::runScene(run).exit_code;
  }
  if (*cmd_replay) {
    haptics::Recording rec;
    try {
      rec = haptics::readRecording(replay_file);
    } catch (const std::exception& e) {
      std::cerr << "error: " << e.what() << "\n";
      return 2;
    }
    app::RunOptions o;
    o.scene = rec.scene;
    o.sets = rec.sets;
    o.replay = &rec;
    o.write_output = false;
    const app::RunResult r = app::runScene(o);
    if (r.exit_code == 0)
      std::cout << "replay: " << r.replay_frames_checked << " frames, every state hash equal to the recording\n";
    return r.exit_code;
  }
  if (*cmd_validate) {
    double bytes = 0;
    if (!maxMemory(validate_max_memory, bytes)) return kExitBadInput;
    return app::validateCommand(validate_files, bytes);
  }
  if (*cmd_schema) return app::schemaCommand();
  if (*cmd_devices) return app::devicesCommand();
  if (*cmd_bench) return app::benchCommand(bench);
  if (*cmd_compare) return app::compareCommand(compare, std::cout, std::cerr);
  if (*cmd_forces) return app::forcesCommand(forces, std::cout, std::cerr);
  if (*cmd_view) {
#ifdef SPHAPTICS_HAVE_VIEWER
    return viewer::viewCommand(view);
#else
    std::cerr << "view: this sphaptics was built without the viewer (GLFW 3.3, OpenGL or Dear ImGui were not found "
                 "when it was configured; Debian: apt-get install libglfw3-dev libgl-dev libimgui-dev libstb-dev, "
                 "then build again)\n";
    return kExitDevice;
#endif
  }
  return kExitBadInput;
}
