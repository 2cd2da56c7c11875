// haptics.csv read back for the haptics tests (batch and live write the same columns).
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace sph::testing {

// One row of haptics.csv: time, x, y, z, ax, ay, az, fx, fy, fz, body, energy, flags.
struct Tick {
  double t = 0;
  Eigen::Vector3d x, a, f;
  long body = -1;
  double energy = 0;
  unsigned flags = 0;
};

inline std::vector<Tick> readHaptics(const std::filesystem::path& file) {
  std::vector<Tick> rows;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("time", 0) == 0) continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream s(line);
    Tick r;
    s >> r.t >> r.x.x() >> r.x.y() >> r.x.z() >> r.a.x() >> r.a.y() >> r.a.z() >> r.f.x() >> r.f.y() >> r.f.z() >>
        r.body >> r.energy >> r.flags;
    rows.push_back(r);
  }
  return rows;
}

}  // namespace sph::testing
