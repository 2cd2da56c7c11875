#include "core/mesh_distance.h"

#include <map>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace sph {

Eigen::Vector3d closestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c, TriangleFeature* feature) {
  // Voronoi regions of the vertices, then of the edges, else the face (barycentric).
  TriangleFeature unused;
  TriangleFeature& f = feature ? *feature : unused;
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return f = TriangleFeature::VertexA, a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return f = TriangleFeature::VertexB, b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return f = TriangleFeature::EdgeAB, a + ab * (d1 / (d1 - d3));
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return f = TriangleFeature::VertexC, c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return f = TriangleFeature::EdgeCA, a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return f = TriangleFeature::EdgeBC, b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = va + vb + vc;
  if (!(std::abs(denom) > 0)) return f = TriangleFeature::VertexA, a;  // degenerate triangle
  const double v = vb / denom, w = vc / denom;
  f = TriangleFeature::Face;
  return a + ab * v + ac * w;
}

struct SurfaceIndex::Impl {
  std::vector<Eigen::Vector3d> v;
  std::vector<std::array<uint32_t, 3>> tris;
  Eigen::Vector3d lo{0, 0, 0};
  double cell = 1;
  Eigen::Vector3i dims{0, 0, 0};
  std::vector<uint32_t> start;  // cell -> first entry in items (CSR)
  std::vector<uint32_t> items;  // triangle indices
  std::vector<Eigen::Vector3d> tlo, thi;  // each triangle's bounding box (unit: m)

  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const {
    Eigen::Vector3i c;
    for (int k = 0; k < 3; ++k)
      c[k] = std::clamp(static_cast<int>(std::floor((p[k] - lo[k]) / cell)), 0, dims[k] - 1);
    return c;
  }
  std::size_t flat(int i, int j, int k) const {
    return static_cast<std::size_t>(i) + static_cast<std::size_t>(dims[0]) * (static_cast<std::size_t>(j) + static_cast<std::size_t>(dims[1]) * static_cast<std::size_t>(k));
  }
};

SurfaceIndex::SurfaceIndex(const TriMesh& mesh) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.v.reserve(mesh.positions.size());
  for (const auto& p : mesh.positions) m.v.push_back(p.cast<double>());
  m.tris = mesh.triangles;
  if (m.tris.empty()) return;
  Eigen::Vector3d lo = m.v[m.tris[0][0]], hi = lo;
  double edge_sum = 0;
  for (const auto& t : m.tris)
    for (int k = 0; k < 3; ++k) {
      lo = lo.cwiseMin(m.v[t[k]]);
      hi = hi.cwiseMax(m.v[t[k]]);
      edge_sum += (m.v[t[k]] - m.v[t[(k + 1) % 3]]).norm();
    }
  // Cells about two mean edge lengths wide, at most ~2M cells.
  const Eigen::Vector3d ext = (hi - lo).cwiseMax(1e-9);
  double cell = std::max(2.0 * edge_sum / (3.0 * static_cast<double>(m.tris.size())), 1e-9);
  while ((ext / cell).array().ceil().prod() > 2e6) cell *= 1.5;
  m.lo = lo;
  m.cell = cell;
  for (int k = 0; k < 3; ++k) m.dims[k] = std::max(1, static_cast<int>(std::ceil(ext[k] / cell)));
  const std::size_t ncell = static_cast<std::size_t>(m.dims.cast<long>().prod());
  // Two passes (count, fill) over the cells each triangle's bounding box touches.
  std::vector<uint32_t> count(ncell + 1, 0);
  auto forCells = [&](const std::array<uint32_t, 3>& t, auto&& fn) {
    Eigen::Vector3d tlo = m.v[t[0]].cwiseMin(m.v[t[1]]).cwiseMin(m.v[t[2]]);
    Eigen::Vector3d thi = m.v[t[0]].cwiseMax(m.v[t[1]]).cwiseMax(m.v[t[2]]);
    const Eigen::Vector3i a = m.cellOf(tlo), b = m.cellOf(thi);
    for (int k = a.z(); k <= b.z(); ++k)
      for (int j = a.y(); j <= b.y(); ++j)
        for (int i = a.x(); i <= b.x(); ++i) fn(m.flat(i, j, k));
  };
  for (const auto& t : m.tris) forCells(t, [&](std::size_t c) { ++count[c + 1]; });
  for (std::size_t c = 0; c < ncell; ++c) count[c + 1] += count[c];
  m.start = count;
  m.items.resize(count[ncell]);
  for (uint32_t ti = 0; ti < m.tris.size(); ++ti) forCells(m.tris[ti], [&](std::size_t c) { m.items[count[c]++] = ti; });
  for (const auto& t : m.tris) {
    m.tlo.push_back(m.v[t[0]].cwiseMin(m.v[t[1]]).cwiseMin(m.v[t[2]]));
    m.thi.push_back(m.v[t[0]].cwiseMax(m.v[t[1]]).cwiseMax(m.v[t[2]]));
  }
}

SurfaceIndex::~SurfaceIndex() = default;

double SurfaceIndex::distance(const Eigen::Vector3d& p) const { return nearest(p).distance; }

SurfaceIndex::Nearest SurfaceIndex::nearest(const Eigen::Vector3d& p, double max_distance) const {
  const Impl& m = *impl_;
  Nearest best;
  if (m.tris.empty()) return best;
  const Eigen::Vector3i c = m.cellOf(p);
  // Distance from p to the grid box: cells beyond ring r are at least r * cell + outside away.
  const Eigen::Vector3d hi = m.lo + m.cell * m.dims.cast<double>();
  const double outside = (m.lo - p).cwiseMax(p - hi).cwiseMax(0.0).norm();
  if (outside > max_distance) return best;
  double best2 = max_distance * max_distance;  // only points within reach count
  bool found = false;
  const int max_ring = m.dims.maxCoeff();
  for (int r = 0; r <= max_ring; ++r) {
    for (int k = c.z() - r; k <= c.z() + r; ++k) {
      if (k < 0 || k >= m.dims.z()) continue;
      for (int j = c.y() - r; j <= c.y() + r; ++j) {
        if (j < 0 || j >= m.dims.y()) continue;
        for (int i = c.x() - r; i <= c.x() + r; ++i) {
          if (i < 0 || i >= m.dims.x()) continue;
          if (std::max({std::abs(i - c.x()), std::abs(j - c.y()), std::abs(k - c.z())}) != r) continue;  // shell only
          const std::size_t f = m.flat(i, j, k);
          for (uint32_t s = m.start[f]; s < m.start[f + 1]; ++s) {
            // A triangle whose bounding box is farther than the best so far cannot replace it (nor a
            // triangle met again in a later cell): skipped without its closest point.
            const uint32_t ti = m.items[s];
            if ((m.tlo[ti] - p).cwiseMax(p - m.thi[ti]).cwiseMax(0.0).squaredNorm() > best2) continue;
            const auto& t = m.tris[ti];
            TriangleFeature feature;
            const Eigen::Vector3d q = closestPointOnTriangle(p, m.v[t[0]], m.v[t[1]], m.v[t[2]], &feature);
            const double d2 = (q - p).squaredNorm();
            if (d2 < best2 || (!found && d2 <= best2)) {
              best2 = d2;
              found = true;
              best.point = q;
              best.triangle = m.items[s];
              best.feature = feature;
            }
          }
        }
      }
    }
    // Done when everything unvisited is farther than the best so far (or than the reach). Unvisited
    // cells are at least r cells away; with p inside the grid, at least as far as the nearest face of
    // the block of cells visited, on the sides where the block has not reached the grid's edge
    // (nothing lies beyond it): a search within a short reach then ends after ring 0 where p is that
    // far inside its cell (session 41: the same nearest point, ~90 % of a mesh-contact solve's time).
    double bound = std::max(static_cast<double>(r) * m.cell, outside);
    if (outside == 0.0) {
      double block = std::numeric_limits<double>::infinity();
      for (int a = 0; a < 3; ++a) {
        if (c[a] - r > 0) block = std::min(block, p[a] - (m.lo[a] + (c[a] - r) * m.cell));
        if (c[a] + r + 1 < m.dims[a]) block = std::min(block, m.lo[a] + (c[a] + r + 1) * m.cell - p[a]);
      }
      bound = std::max(bound, block);
    }
    if (best2 <= bound * bound) break;
  }
  if (found) best.distance = std::sqrt(best2);
  return best;
}

double hausdorffOneSided(const TriMesh& from, const TriMesh& to) {
  if (from.triangles.empty()) return 0.0;
  if (to.triangles.empty()) return std::numeric_limits<double>::infinity();
  const SurfaceIndex index(to);
  double worst = 0.0;
  for (const auto& p : from.positions) worst = std::max(worst, index.distance(p.cast<double>()));
  for (const auto& t : from.triangles) {
    const Eigen::Vector3d centroid =
        (from.positions[t[0]].cast<double>() + from.positions[t[1]].cast<double>() + from.positions[t[2]].cast<double>()) / 3.0;
    worst = std::max(worst, index.distance(centroid));
  }
  return worst;
}

double hausdorff(const TriMesh& a, const TriMesh& b) { return std::max(hausdorffOneSided(a, b), hausdorffOneSided(b, a)); }

// --- ClosedSurface ------------------------------------------------------------------------------

ClosedSurface::ClosedSurface(const TriMesh& mesh) : mesh_(mesh), index_(mesh) {
  // Face normals; the angle at each corner weights the vertex normals; each edge sums the
  // normals of its two faces (keyed by its vertex pair, either direction).
  auto vertex = [&](uint32_t i) { return mesh.positions[i].cast<double>(); };
  vertex_normal_.assign(mesh.positions.size(), Eigen::Vector3d::Zero());
  std::map<std::pair<uint32_t, uint32_t>, Eigen::Vector3d> edge_sum;
  auto key = [](uint32_t i, uint32_t j) { return std::make_pair(std::min(i, j), std::max(i, j)); };
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = vertex(t[0]), b = vertex(t[1]), c = vertex(t[2]);
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    face_normal_.push_back(n);
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d o = vertex(t[k]);
      const Eigen::Vector3d u = (vertex(t[(k + 1) % 3]) - o).normalized();
      const Eigen::Vector3d w = (vertex(t[(k + 2) % 3]) - o).normalized();
      vertex_normal_[t[k]] += std::acos(std::clamp(u.dot(w), -1.0, 1.0)) * n;
      auto [it, fresh] = edge_sum.try_emplace(key(t[k], t[(k + 1) % 3]), Eigen::Vector3d::Zero());
      it->second += n;
    }
  }
  for (auto& n : vertex_normal_) n.normalize();
  for (const auto& t : mesh.triangles) {
    std::array<Eigen::Vector3d, 3> e;
    for (int k = 0; k < 3; ++k) e[k] = edge_sum.at(key(t[k], t[(k + 1) % 3])).normalized();
    edge_normal_.push_back(e);
  }
}

const Eigen::Vector3d& ClosedSurface::pseudoNormal(uint32_t t, TriangleFeature f) const {
  switch (f) {
    case TriangleFeature::Face: return face_normal_[t];
    case TriangleFeature::VertexA: return vertex_normal_[mesh_.triangles[t][0]];
    case TriangleFeature::VertexB: return vertex_normal_[mesh_.triangles[t][1]];
    case TriangleFeature::VertexC: return vertex_normal_[mesh_.triangles[t][2]];
    case TriangleFeature::EdgeAB: return edge_normal_[t][0];
    case TriangleFeature::EdgeBC: return edge_normal_[t][1];
    case TriangleFeature::EdgeCA: return edge_normal_[t][2];
  }
  return face_normal_[t];
}

bool ClosedSurface::inside(const Eigen::Vector3d& p, double& distance) const {
  const SurfaceIndex::Nearest near = index_.nearest(p);
  distance = near.distance;
  if (!std::isfinite(near.distance)) return false;
  return pseudoNormal(near.triangle, near.feature).dot(p - near.point) <= 0.0;
}

bool ClosedSurface::inside(const Eigen::Vector3d& p) const {
  double distance = 0;
  return inside(p, distance);
}

}  // namespace sph
