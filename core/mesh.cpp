#include "core/mesh.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>
#include <utility>

namespace sph {

double meshVolume(const TriMesh& m) {
  double v6 = 0.0;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d a = m.positions[t[0]].cast<double>();
    const Eigen::Vector3d b = m.positions[t[1]].cast<double>();
    const Eigen::Vector3d c = m.positions[t[2]].cast<double>();
    v6 += a.dot(b.cross(c));
  }
  return v6 / 6.0;
}

double meshArea(const TriMesh& m) {
  double area = 0.0;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d a = m.positions[t[0]].cast<double>();
    const Eigen::Vector3d b = m.positions[t[1]].cast<double>();
    const Eigen::Vector3d c = m.positions[t[2]].cast<double>();
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return area;
}

double windingNumber(const TriMesh& m, const Eigen::Vector3d& p) {
  double total = 0.0;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d a = m.positions[t[0]].cast<double>() - p;
    const Eigen::Vector3d b = m.positions[t[1]].cast<double>() - p;
    const Eigen::Vector3d c = m.positions[t[2]].cast<double>() - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double numerator = a.dot(b.cross(c));
    const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    total += 2.0 * std::atan2(numerator, denominator);
  }
  return total / (4.0 * M_PI);
}

EdgeReport checkEdges(const TriMesh& m) {
  // Directed edge counts keyed by (min, max) with the count of each direction.
  std::map<std::pair<uint32_t, uint32_t>, std::array<uint32_t, 2>> edges;
  EdgeReport r;
  for (const auto& t : m.triangles) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++r.degenerate;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      auto& e = edges[{std::min(a, b), std::max(a, b)}];
      ++e[a < b ? 0 : 1];
    }
  }
  r.edges = edges.size();
  for (const auto& [key, c] : edges) {
    const uint32_t total = c[0] + c[1];
    if (total == 1) ++r.boundary;
    else if (total > 2) ++r.nonmanifold;
    else if (c[0] != 1) ++r.misoriented;
  }
  return r;
}

void weldVertices(TriMesh& m, float tolerance) {
  // Hash on a grid of cell `tolerance`; a vertex merges with the first earlier vertex within
  // tolerance in the 27 surrounding cells.
  const float cell = std::max(tolerance, 1e-12f);
  auto key = [cell](const Eigen::Vector3f& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / cell)), static_cast<int>(std::floor(p.y() / cell)),
                           static_cast<int>(std::floor(p.z() / cell)));
  };
  auto hash = [](const Eigen::Vector3i& k) {
    return (static_cast<uint64_t>(static_cast<uint32_t>(k.x())) * 73856093u) ^
           (static_cast<uint64_t>(static_cast<uint32_t>(k.y())) * 19349663u) ^
           (static_cast<uint64_t>(static_cast<uint32_t>(k.z())) * 83492791u);
  };
  std::unordered_multimap<uint64_t, uint32_t> table;
  std::vector<uint32_t> remap(m.positions.size());
  TriMesh out;
  for (uint32_t i = 0; i < m.positions.size(); ++i) {
    const Eigen::Vector3f& p = m.positions[i];
    const Eigen::Vector3i k = key(p);
    int64_t found = -1;
    for (int dz = -1; dz <= 1 && found < 0; ++dz)
      for (int dy = -1; dy <= 1 && found < 0; ++dy)
        for (int dx = -1; dx <= 1 && found < 0; ++dx) {
          auto range = table.equal_range(hash(k + Eigen::Vector3i(dx, dy, dz)));
          for (auto it = range.first; it != range.second; ++it)
            if ((out.positions[it->second] - p).norm() <= tolerance &&
                (found < 0 || it->second < static_cast<uint32_t>(found)))
              found = it->second;
        }
    if (found >= 0) {
      remap[i] = static_cast<uint32_t>(found);
      continue;
    }
    remap[i] = static_cast<uint32_t>(out.positions.size());
    table.emplace(hash(k), remap[i]);
    out.positions.push_back(p);
    if (!m.normals.empty()) out.normals.push_back(m.normals[i]);
    if (!m.colours.empty()) out.colours.push_back(m.colours[i]);
  }
  for (const auto& t : m.triangles) {
    const std::array<uint32_t, 3> r{remap[t[0]], remap[t[1]], remap[t[2]]};
    if (r[0] != r[1] && r[1] != r[2] && r[0] != r[2]) out.triangles.push_back(r);
  }
  m = std::move(out);
}

}  // namespace sph
