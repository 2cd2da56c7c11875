#include "io/obj_io.h"

#include "core/errors.h"
#include "io/atomic_file.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <filesystem>
#include <sstream>

namespace sph::io {

namespace {

// tinyobjloader skips what it does not know; a file with text that is not OBJ is reported here,
// with its line, rather than read as an empty or partial mesh.
void checkObjKeywords(const std::string& path) {
  static const char* const known[] = {"v", "vn", "vt", "vp", "f", "l", "p", "o", "g", "s", "usemtl", "mtllib",
                                      "cstype", "deg", "curv", "curv2", "surf", "parm", "trim", "hole", "end"};
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path, 0, 0, "cannot open mesh file");
  std::string line;
  for (int n = 1; std::getline(f, line); ++n) {
    std::istringstream words(line);
    std::string kw;
    if (!(words >> kw) || kw[0] == '#') continue;
    if (std::find(std::begin(known), std::end(known), kw) == std::end(known))
      throw InputError(path, n, 1, "not an OBJ line: '" + line.substr(0, 40) + "'");
    if (kw == "v" || kw == "vn") {
      double x, y, z;
      if (!(words >> x >> y >> z)) throw InputError(path, n, 1, "'" + kw + "' needs three numbers");
    }
  }
}

}  // namespace

TriMesh readObj(const std::string& path, bool allow_empty) {
  if (!std::filesystem::exists(path)) throw InputError(path, 0, 0, "mesh file not found");
  checkObjKeywords(path);
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = true;
  tinyobj::ObjReader reader;
  if (!reader.ParseFromFile(path, config)) {
    std::string msg = reader.Error();
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == '\r')) msg.pop_back();
    throw InputError(path, 0, 0, "cannot read OBJ mesh: " + (msg.empty() ? std::string("parse error") : msg));
  }
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  TriMesh m;
  const std::size_t nv = attrib.vertices.size() / 3;
  m.positions.reserve(nv);
  for (std::size_t i = 0; i < nv; ++i)
    m.positions.emplace_back(attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]);
  // Per-vertex normals only when every face corner names the normal of the same index.
  bool normals_per_vertex = !attrib.normals.empty();
  std::vector<Eigen::Vector3f> normals(nv, Eigen::Vector3f::Zero());
  for (const auto& shape : reader.GetShapes()) {
    const auto& idx = shape.mesh.indices;
    for (std::size_t f = 0; f + 2 < idx.size(); f += 3) {
      std::array<uint32_t, 3> t{};
      for (int k = 0; k < 3; ++k) {
        const auto& c = idx[f + static_cast<std::size_t>(k)];
        if (c.vertex_index < 0 || static_cast<std::size_t>(c.vertex_index) >= nv)
          throw InputError(path, 0, 0, "face refers to a vertex that does not exist");
        t[static_cast<std::size_t>(k)] = static_cast<uint32_t>(c.vertex_index);
        if (c.normal_index < 0) {
          normals_per_vertex = false;
        } else if (normals_per_vertex) {
          const std::size_t n = static_cast<std::size_t>(c.normal_index);
          normals[t[static_cast<std::size_t>(k)]] = Eigen::Vector3f(attrib.normals[3 * n], attrib.normals[3 * n + 1], attrib.normals[3 * n + 2]);
        }
      }
      m.triangles.push_back(t);
    }
  }
  if (m.triangles.empty() && !allow_empty) throw InputError(path, 0, 0, "OBJ mesh has no faces");
  if (normals_per_vertex) m.normals = std::move(normals);
  // Per-vertex colours (`v x y z r g b`): tinyobjloader gives white to vertices without one, so
  // an all-white list is taken as no colours.
  if (attrib.colors.size() == 3 * nv &&
      std::any_of(attrib.colors.begin(), attrib.colors.end(), [](tinyobj::real_t c) { return c != 1.0f; })) {
    m.colours.reserve(nv);
    for (std::size_t i = 0; i < nv; ++i)
      m.colours.emplace_back(attrib.colors[3 * i], attrib.colors[3 * i + 1], attrib.colors[3 * i + 2]);
  }
  return m;
}

std::string objText(const TriMesh& m, const std::string& comment) {
  std::string out;
  out.reserve(m.positions.size() * 80 + m.triangles.size() * 40);
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);) out += "# " + line + "\n";
  char buf[160];
  const bool colours = m.colours.size() == m.positions.size() && !m.colours.empty();
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    const auto& p = m.positions[i];
    int n = colours ? std::snprintf(buf, sizeof buf, "v %.6g %.6g %.6g %.4g %.4g %.4g\n", p.x(), p.y(), p.z(),
                                    m.colours[i].x(), m.colours[i].y(), m.colours[i].z())
                    : std::snprintf(buf, sizeof buf, "v %.6g %.6g %.6g\n", p.x(), p.y(), p.z());
    out.append(buf, static_cast<std::size_t>(n));
  }
  const bool normals = m.normals.size() == m.positions.size() && !m.normals.empty();
  if (normals)
    for (const auto& v : m.normals) {
      int n = std::snprintf(buf, sizeof buf, "vn %.5g %.5g %.5g\n", v.x(), v.y(), v.z());
      out.append(buf, static_cast<std::size_t>(n));
    }
  for (const auto& t : m.triangles) {
    int n = normals ? std::snprintf(buf, sizeof buf, "f %u//%u %u//%u %u//%u\n", t[0] + 1, t[0] + 1, t[1] + 1,
                                    t[1] + 1, t[2] + 1, t[2] + 1)
                    : std::snprintf(buf, sizeof buf, "f %u %u %u\n", t[0] + 1, t[1] + 1, t[2] + 1);
    out.append(buf, static_cast<std::size_t>(n));
  }
  return out;
}

void writeObj(const std::string& path, const TriMesh& m, const std::string& comment) {
  writeFileAtomic(path, objText(m, comment));
}

}  // namespace sph::io
