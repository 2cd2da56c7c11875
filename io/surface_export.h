// Names and headers of the isosurface OBJ sequence: fluid_<phase>_%04d.obj, one file per output
// frame and phase (frame 0 is the initial state, as Step#0 of particles.h5part).
#pragma once

#include <string>

namespace sph::io {

/// "fluid_<phase>_0007.obj"; characters outside [A-Za-z0-9_-] in the phase name become '_'.
std::string surfaceObjName(const std::string& phase, int frame);

/// "fluid_0007.vdb": the surface field of every phase in one OpenVDB file per output frame.
std::string surfaceVdbName(int frame);
/// The grid name of a phase's field in that file: "density_<phase>" (sanitised as above); the
/// sum over phases is the grid "density".
std::string surfaceVdbGridName(const std::string& phase);

/// What a surface OBJ's header records. `sphaptics compare` reads `particle_spacing` from it.
struct SurfaceObjInfo {
  double particle_spacing = 0;  ///< dx (unit: m)
  double time = 0;              ///< simulated time of the frame (unit: s)
  int frame = 0;                ///< output frame index
  std::string phase;            ///< phase name
  float colour[3] = {0, 0, 0};  ///< the phase's colour, linear RGB in [0, 1]
  double iso = 0.5;             ///< iso value of the normalised field (unit: 1)
  double grid_spacing = 0;      ///< surface grid spacing (unit: m)
};

/// The comment lines (without '#'), one key per line: "particle_spacing: 0.01 m", ...
std::string surfaceObjComment(const SurfaceObjInfo& info);

}  // namespace sph::io
