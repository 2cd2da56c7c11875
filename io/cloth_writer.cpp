#include "io/cloth_writer.h"

#include "io/obj_io.h"

#include <cstdio>
#include <map>
#include <stdexcept>
#include <utility>

namespace sph::io {

TriMesh clothMesh(const cloth::ClothModel& model, std::size_t c, const ClothSpec& spec,
                  const std::vector<Eigen::Vector4f>& x, const std::vector<uint32_t>& broken) {
  TriMesh m;
  const uint32_t base = model.first_node[c], n = model.num_nodes[c];
  const int nx = spec.resolution_x, ny = spec.resolution_y;
  for (uint32_t k = 0; k < n; ++k) {
    m.positions.push_back(x[base + k].head<3>());
    m.colours.push_back(spec.colour.cast<float>());
  }
  // Springs by their ends, to look up an edge's spring.
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> spring_of;
  for (uint32_t s = model.first_spring[c]; s < model.first_spring[c] + model.num_springs[c]; ++s)
    if (model.kind[s] != cloth::kBend) spring_of[{model.ends[2 * s], model.ends[2 * s + 1]}] = s;
  // An edge is whole unless its spring broke (an edge without a spring, a diagonal without shear
  // springs, is whole).
  auto whole = [&](uint32_t a, uint32_t b) {
    const auto it = spring_of.find({std::min(a, b), std::max(a, b)});
    return it == spring_of.end() || broken.empty() || !broken[it->second];
  };
  // A mesh cloth: its own triangles, less those along a broken edge.
  if (spec.isMesh()) {
    for (const auto& t : spec.mesh_data.triangles)
      if (whole(base + t[0], base + t[1]) && whole(base + t[1], base + t[2]) && whole(base + t[2], base + t[0]))
        m.triangles.push_back(t);
    return m;
  }
  auto id = [&](int i, int j) { return base + static_cast<uint32_t>(j * nx + i); };
  // Two triangles per cell, counter-clockwise seen from the cloth's +z side, split along (i,j)-(i+1,j+1).
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const uint32_t a = id(i, j), b = id(i + 1, j), cc = id(i + 1, j + 1), d = id(i, j + 1);
      if (whole(a, b) && whole(b, cc) && whole(a, cc)) m.triangles.push_back({a - base, b - base, cc - base});
      if (whole(a, cc) && whole(cc, d) && whole(d, a)) m.triangles.push_back({a - base, cc - base, d - base});
    }
  return m;
}

TriMesh softMesh(const cloth::ClothModel& model, std::size_t b, const Eigen::Vector3d& colour,
                 const std::vector<Eigen::Vector4f>& x, const std::vector<uint32_t>& broken) {
  TriMesh m;
  const std::size_t item = model.num_cloths + b;
  const uint32_t base = model.first_node[item], n = model.num_nodes[item];
  for (uint32_t k = 0; k < n; ++k) {
    m.positions.push_back(x[base + k].head<3>());
    m.colours.push_back(colour.cast<float>());
  }
  const cloth::ClothModel::SoftCells& cells = model.soft[b];
  // Intact cells on the bounding grid (-1: no intact cell there).
  const std::array<int, 3>& nc = cells.cells_per_axis;
  std::vector<int64_t> at(static_cast<std::size_t>(nc[0]) * nc[1] * nc[2], -1);
  auto index = [&](int i, int j, int k) { return (static_cast<std::size_t>(k) * nc[1] + j) * nc[0] + i; };
  for (std::size_t c = 0; c < cells.ijk.size(); ++c) {
    bool intact = true;
    for (uint32_t s : cells.springs[c]) intact = intact && (broken.empty() || !broken[s]);
    if (intact) at[index(cells.ijk[c][0], cells.ijk[c][1], cells.ijk[c][2])] = static_cast<int64_t>(c);
  }
  // The six faces of a cell as corner quads (corner bits x, y, z), counter-clockwise seen from
  // outside, and the neighbour across each.
  static const int quad[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  static const int step[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
  for (std::size_t c = 0; c < cells.ijk.size(); ++c) {
    const auto& ijk = cells.ijk[c];
    if (at[index(ijk[0], ijk[1], ijk[2])] < 0) continue;
    for (int f = 0; f < 6; ++f) {
      const int i = ijk[0] + step[f][0], j = ijk[1] + step[f][1], k = ijk[2] + step[f][2];
      const bool inside = i >= 0 && j >= 0 && k >= 0 && i < nc[0] && j < nc[1] && k < nc[2];
      if (inside && at[index(i, j, k)] >= 0) continue;  // shared with an intact cell: not surface
      uint32_t v[4];
      for (int q = 0; q < 4; ++q) v[q] = cells.nodes[c][quad[f][q]] - base;
      m.triangles.push_back({v[0], v[1], v[2]});
      m.triangles.push_back({v[0], v[2], v[3]});
    }
  }
  return m;
}

std::string clothCsvHeader(bool soft) {
  if (soft)
    return "# sphaptics soft.csv: one row per soft body per output frame. Units: s, J, N; strain (L - L0) / L0.\n"
           "# potential: gravity, -m g.x summed over the free nodes; elastic: T^2 / 2k per spring (T: k (L - L0),\n"
           "# XPBD: its constraint force); anchor_f*: force of the springs on the anchored nodes (world frame).\n"
           "time,soft_body,kinetic,potential,elastic,energy,max_strain,broken_springs,anchor_fx,anchor_fy,anchor_fz\n";
  return "# sphaptics cloth.csv: one row per cloth per output frame. Units: s, J, N; strain (L - L0) / L0.\n"
         "# potential: gravity, -m g.x summed over the free nodes; elastic: T^2 / 2k per spring (T: k (L - L0),\n"
         "# XPBD: its constraint force); anchor_f*: force of the springs on the anchored nodes (world frame).\n"
         "time,cloth,kinetic,potential,elastic,energy,max_strain,broken_springs,anchor_fx,anchor_fy,anchor_fz\n";
}

std::string softObjName(const std::string& name, int frame) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "_%04d.obj", frame);
  return "soft_" + name + buf;
}

std::string clothObjName(const std::string& name, int frame) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "_%04d.obj", frame);
  return "cloth_" + name + buf;
}

ClothCsvWriter::ClothCsvWriter(const std::string& path, bool soft) : path_(path), out_(path) {
  if (!out_) throw std::runtime_error("cannot write " + path);
  out_ << clothCsvHeader(soft);
}

void ClothCsvWriter::writeRow(double time, const std::string& name, const cloth::ClothReport& r) {
  char buf[512];
  std::snprintf(buf, sizeof buf, "%.9g,%s,%.9g,%.9g,%.9g,%.9g,%.9g,%u,%.9g,%.9g,%.9g\n", time, name.c_str(), r.kinetic,
                r.potential, r.elastic, r.energy(), r.max_strain, r.broken, r.anchor_force.x(), r.anchor_force.y(),
                r.anchor_force.z());
  out_ << buf;
}

void ClothCsvWriter::close() {
  out_.close();
  if (!out_) throw std::runtime_error("writing " + path_ + " failed");
}

}  // namespace sph::io
