#include "io/bodies_writer.h"

#include "core/simulation.h"
#include "io/obj_io.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace sph::io {

std::string bodiesCsvHeader() {
  return "# sphaptics rigid bodies, one row per body per output frame. SI units: s, m, m/s, rad/s, N, N m.\n"
         "# com_*: centre of mass (world); q*: orientation quaternion body -> world (w, x, y, z);\n"
         "# v*: velocity of the centre of mass; w*: angular velocity (world frame).\n"
         "# fluid_f*, fluid_t*: the fluid's force and torque about the centre of mass in the frame's last step\n"
         "# (the fluid's pressure, viscous and contact forces, and with DFSPH a dynamic body's fictitious-mass\n"
         "# force M (a_{n-1} - a_n), fluid.dfsph.body_added_mass; 0 for static bodies);\n"
         "# contact_f*: the contact force in that step, from the closed walls and other bodies (on static and\n"
         "# kinematic bodies: the reaction of the dynamic ones they touch).\n"
         "time,body,com_x,com_y,com_z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz,"
         "fluid_fx,fluid_fy,fluid_fz,fluid_tx,fluid_ty,fluid_tz,contact_fx,contact_fy,contact_fz\n";
}

BodiesCsvWriter::BodiesCsvWriter(const std::string& path) : path_(path), out_(path, std::ios::trunc) {
  if (!out_) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
  out_ << bodiesCsvHeader();
}

void BodiesCsvWriter::writeFrame(double time, const std::vector<rigid::RigidBody>& bodies,
                                 const std::vector<rigid::BodyState>& states) {
  char buf[64];
  auto num = [&](double v) {
    std::snprintf(buf, sizeof buf, ",%.9g", v);
    out_ << buf;
  };
  auto vec = [&](const Eigen::Vector3d& v) { num(v.x()), num(v.y()), num(v.z()); };
  for (std::size_t b = 0; b < bodies.size() && b < states.size(); ++b) {
    const rigid::BodyState& s = states[b];
    std::snprintf(buf, sizeof buf, "%.9g", time);
    out_ << buf << "," << bodies[b].spec.name;
    vec(s.x);
    num(s.q.w()), num(s.q.x()), num(s.q.y()), num(s.q.z());
    vec(s.v);
    vec(s.w);
    vec(s.fluid_force);
    vec(s.fluid_torque);
    vec(s.contact_force);
    out_ << "\n";
  }
  errno = 0;  // so that a failed flush names its own reason
  out_.flush();
  if (!out_) throw std::runtime_error("cannot write " + path_ + ": " + std::strerror(errno ? errno : EIO));
}

void BodiesCsvWriter::close() {
  if (out_.is_open()) out_.close();
}

StepForcesCsvWriter::StepForcesCsvWriter(const std::string& path) : path_(path), out_(path, std::ios::trunc) {
  if (!out_) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
  out_ << "# sphaptics per-step fluid forces on the moving bodies (output.step_forces), one row per body per time step.\n"
          "# SI units: s, m/s, rad/s, N, N m. time: start of the step (the pose the force acts at); v*, w*: the body's\n"
          "# velocity and angular velocity (world); fluid_f*, fluid_t*: the fluid's force and torque about the centre of mass\n"
          "# (with DFSPH, a dynamic body's force includes its fictitious-mass force, fluid.dfsph.body_added_mass).\n"
          "time,body,vx,vy,vz,wx,wy,wz,fluid_fx,fluid_fy,fluid_fz,fluid_tx,fluid_ty,fluid_tz\n";
}

void StepForcesCsvWriter::write(const std::vector<StepForce>& rows, const std::vector<rigid::RigidBody>& bodies) {
  char buf[64];
  auto vec = [&](const Eigen::Vector3d& v) {
    std::snprintf(buf, sizeof buf, ",%.9g,%.9g,%.9g", v.x(), v.y(), v.z());
    out_ << buf;
  };
  for (const StepForce& r : rows) {
    std::snprintf(buf, sizeof buf, "%.12g", r.time);
    out_ << buf << "," << (r.body < bodies.size() ? bodies[r.body].spec.name : std::string("?"));
    vec(r.v);
    vec(r.w);
    vec(r.force);
    vec(r.torque);
    out_ << "\n";
  }
  errno = 0;  // so that a failed flush names its own reason
  out_.flush();
  if (!out_) throw std::runtime_error("cannot write " + path_ + ": " + std::strerror(errno ? errno : EIO));
}

void StepForcesCsvWriter::close() {
  if (out_.is_open()) out_.close();
}

void writeBodyObjs(const std::string& dir, int frame, const std::vector<rigid::RigidBody>& bodies,
                   const std::vector<rigid::BodyState>& states) {
  char name[32];
  std::snprintf(name, sizeof name, "_%04d.obj", frame);
  for (std::size_t b = 0; b < bodies.size() && b < states.size(); ++b) {
    const std::string path = (std::filesystem::path(dir) / ("body_" + bodies[b].spec.name + name)).string();
    writeObj(path, rigid::worldMesh(bodies[b], states[b]), "rigid body " + bodies[b].spec.name + ", world coordinates");
  }
}

}  // namespace sph::io
