// Rigid-body output: bodies.csv (one row per body per output frame) and the bodies' meshes in
// world coordinates, one OBJ per body per frame (body_<name>_NNNN.obj), for Blender or ParaView.
#pragma once

#include "core/rigid.h"

#include <fstream>
#include <string>
#include <vector>

namespace sph {
struct StepForce;  // core/simulation.h
}

namespace sph::io {

/// bodies.csv: opens with '#' lines (units, conventions), then a header row, then one row per
/// body per frame: time, body, centre of mass, orientation quaternion (w, x, y, z; body -> world),
/// linear and angular velocity, fluid force and torque, contact force.
class BodiesCsvWriter {
 public:
  /// Creates (truncates) the file. Throws std::runtime_error naming it when it cannot be opened.
  explicit BodiesCsvWriter(const std::string& path);
  void writeFrame(double time, const std::vector<rigid::RigidBody>& bodies, const std::vector<rigid::BodyState>& states);
  void close();

 private:
  std::string path_;
  std::ofstream out_;
};

/// The header comment and column row of bodies.csv (for documentation and tests).
std::string bodiesCsvHeader();

/// forces.csv (output.step_forces): opens with '#' lines, then a header row, then one row per
/// moving body per time step: step start time, body, velocity, angular velocity, fluid force and
/// torque (the force acting on the body at that time, as in bodies.csv's fluid_* columns).
class StepForcesCsvWriter {
 public:
  /// Creates (truncates) the file. Throws std::runtime_error naming it when it cannot be opened.
  explicit StepForcesCsvWriter(const std::string& path);
  void write(const std::vector<StepForce>& rows, const std::vector<rigid::RigidBody>& bodies);
  void close();

 private:
  std::string path_;
  std::ofstream out_;
};

/// Writes body_<name>_<frame, 4 digits>.obj for every body into `dir`.
void writeBodyObjs(const std::string& dir, int frame, const std::vector<rigid::RigidBody>& bodies,
                   const std::vector<rigid::BodyState>& states);

}  // namespace sph::io
