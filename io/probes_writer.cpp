#include "io/probes_writer.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace sph::io {

std::string probesCsvHeader(const ProbesSpec& spec) {
  std::string h =
      "# sphaptics probes, one row per sample (scene section probes). SI units: s, Pa, kg/m^3, m/s, m.\n"
      "# time: the simulated time of the state sampled (the start of a time step).\n"
      "# <probe>_pressure, _density, _vx.._vz: Shepard-normalised kernel interpolation of the fluid at the\n"
      "# probe's point; nan when the point is not in the fluid (the kernel less than half full of fluid).\n"
      "# <gauge>_height: height of the fluid column standing on the gauge's foot, where the fluid's fill\n"
      "# field falls through 1/2 (the isosurface's level); 0 when the foot is dry.\n";
  for (const PointProbeSpec& p : spec.points) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "# probe %s at (x y z) = (%.9g %.9g %.9g) m\n", p.name.c_str(), p.position.x(),
                  p.position.y(), p.position.z());
    h += buf;
  }
  for (const GaugeSpec& g : spec.gauges) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "# gauge %s: foot at (x y z) = (%.9g %.9g %.9g) m\n", g.name.c_str(), g.position.x(),
                  g.position.y(), g.position.z());
    h += buf;
  }
  h += "time";
  for (const PointProbeSpec& p : spec.points)
    for (const char* f : {"_pressure", "_density", "_vx", "_vy", "_vz"}) h += "," + p.name + f;
  for (const GaugeSpec& g : spec.gauges) h += "," + g.name + "_height";
  return h + "\n";
}

ProbesCsvWriter::ProbesCsvWriter(const std::string& path, const ProbesSpec& spec) : path_(path), out_(path, std::ios::trunc) {
  if (!out_) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
  out_ << probesCsvHeader(spec);
}

void ProbesCsvWriter::write(const std::vector<ProbeSample>& samples) {
  char buf[64];
  auto num = [&](double v) {
    if (std::isnan(v)) out_ << ",nan";
    else {
      std::snprintf(buf, sizeof buf, ",%.9g", v);
      out_ << buf;
    }
  };
  for (const ProbeSample& s : samples) {
    std::snprintf(buf, sizeof buf, "%.9g", s.time);
    out_ << buf;
    for (const ProbeSample::Point& p : s.points) {
      num(p.pressure), num(p.density);
      num(p.velocity.x()), num(p.velocity.y()), num(p.velocity.z());
    }
    for (double h : s.heights) num(h);
    out_ << "\n";
  }
  errno = 0;  // so that a failed flush names its own reason
  out_.flush();
  if (!out_) throw std::runtime_error("cannot write " + path_ + ": " + std::strerror(errno ? errno : EIO));
}

void ProbesCsvWriter::close() {
  if (out_.is_open()) out_.close();
}

}  // namespace sph::io
