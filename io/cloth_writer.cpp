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

std::string clothCsvHeader() {
  return "# sphaptics cloth.csv: one row per cloth per output frame. Units: s, J, N; strain (L - L0) / L0.\n"
         "# potential: gravity, -m g.x summed over the free nodes; elastic: T^2 / 2k per spring (T: k (L - L0),\n"
         "# XPBD: its constraint force); anchor_f*: force of the springs on the anchored nodes (world frame).\n"
         "time,cloth,kinetic,potential,elastic,energy,max_strain,broken_springs,anchor_fx,anchor_fy,anchor_fz\n";
}

std::string clothObjName(const std::string& name, int frame) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "_%04d.obj", frame);
  return "cloth_" + name + buf;
}

ClothCsvWriter::ClothCsvWriter(const std::string& path) : path_(path), out_(path) {
  if (!out_) throw std::runtime_error("cannot write " + path);
  out_ << clothCsvHeader();
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
