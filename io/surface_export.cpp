#include "io/surface_export.h"

#include <cctype>
#include <cstdio>

namespace sph::io {

namespace {
std::string safeName(const std::string& phase) {
  std::string safe = phase;
  for (char& c : safe)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) c = '_';
  return safe;
}
std::string frameNumber(int frame) {
  char num[16];
  std::snprintf(num, sizeof num, "%04d", frame);
  return num;
}
}  // namespace

std::string surfaceObjName(const std::string& phase, int frame) {
  return "fluid_" + safeName(phase) + "_" + frameNumber(frame) + ".obj";
}

std::string surfaceVdbName(int frame) { return "fluid_" + frameNumber(frame) + ".vdb"; }

std::string surfaceVdbGridName(const std::string& phase) { return "density_" + safeName(phase); }

std::string surfaceObjComment(const SurfaceObjInfo& info) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "sphaptics %s fluid surface (marching cubes), world coordinates in metres, Z up\n"
                "particle_spacing: %.9g m\n"
                "time: %.9g s\n"
                "frame: %d\n"
                "phase: %s\n"
                "colour: %.4g %.4g %.4g\n"
                "iso: %.6g\n"
                "grid_spacing: %.9g m",
                SPHAPTICS_VERSION, info.particle_spacing, info.time, info.frame, info.phase.c_str(), info.colour[0],
                info.colour[1], info.colour[2], info.iso,
                info.grid_spacing);
  return buf;
}

}  // namespace sph::io
