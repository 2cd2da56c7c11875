// Options of `sphaptics view RUN_DIR` (header only, so that cli/main.cpp can declare the command
// whether or not this build has the viewer).
#pragma once

#include "core/live_frame.h"
#include "haptics/mouse.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace sph::viewer {

struct ViewOptions {
  std::string dir;                 ///< output folder of a run (finished or still being written)
  std::string screenshot;          ///< PNG to write, then exit; "" = open the window
  std::string frame = "0";         ///< frame for the screenshot (and the first shown): an index or "last"
  int width = 1280;                ///< window / screenshot width (unit: pixels)
  int height = 720;                ///< window / screenshot height (unit: pixels)
  std::string colour = "phase";    ///< particle colour: phase, pressure, speed or density
  std::vector<std::string> hide;   ///< layers switched off at start: particles, surfaces, bodies, box
  double particle_size = 1.0;      ///< sprite radius / half the particle spacing (unit: 1)
  double fps = 0;                  ///< playback rate; 0 = the run's frame rate, i.e. real time (unit: frames/s)
  double benchmark = 0;            ///< > 0: play for this long, print the drawn frames per second, exit (unit: s)
};

/// Layer and colour names the command accepts.
inline const std::vector<std::string>& viewLayerNames() {
  static const std::vector<std::string> names{"particles", "surfaces", "bodies", "box"};
  return names;
}
inline const std::vector<std::string>& viewColourNames() {
  static const std::vector<std::string> names{"phase", "pressure", "speed", "density"};
  return names;
}

/// Opens the viewer (or writes the screenshot). Exit codes: 0 done, 2 bad input (folder, frame,
/// run.json), 3 no window could be opened (no display, no OpenGL 3.3).
int viewCommand(const ViewOptions& opt);

/// Options of the live window over a running simulation (`sphaptics run --interactive` / `--window`).
struct LiveViewOptions {
  std::string title;               ///< window title (the scene file)
  int width = 1280;                ///< (unit: pixels)
  int height = 720;                ///< (unit: pixels)
  std::string colour = "phase";    ///< particle colour: phase, pressure, speed or density
  std::string screenshot;          ///< write the window's last picture (panel included) here when the run ends
};

/// Opens the window over `link` (core/live_frame.h) and draws the newest published frame until the
/// window is closed or `run_done()` turns true; sends pause / reset / stop / gain / smoothing
/// through link->requests and, with `mouse`, the cursor as a haptic device (haptics/mouse.h).
/// Returns 0, or 3 when no window could be opened (the caller then goes on without one).
/// Prints the window's frame rate at the end.
int liveWindow(const LiveViewOptions& opt, std::shared_ptr<LiveLink> link, std::shared_ptr<haptics::MouseInput> mouse,
               const std::function<bool()>& run_done);

}  // namespace sph::viewer
