#include "core/cloth.h"

#include "core/errors.h"
#include "core/mesh_distance.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <sstream>

namespace sph::cloth {

namespace {

// Grid spacing along one axis of a cloth: extent / (nodes - 1); a single node has none.
double spacing(double extent, int nodes) { return nodes > 1 ? extent / (nodes - 1) : 0.0; }

template <class Spec>
Eigen::Matrix3d rotation(const Spec& c) {
  const Eigen::Vector3d axis = c.orientation_axis.norm() > 0 ? c.orientation_axis.normalized() : Eigen::Vector3d::UnitZ();
  return Eigen::AngleAxisd(c.orientation_angle * M_PI / 180.0, axis).toRotationMatrix();
}

// Pins `nodes` (global indices) for anchor `a`: constant velocity until its stop time, or its
// keyframed track (w = -(track + 1); stop times are >= 0).
void pinNodes(ClothModel& m, const ClothAnchorSpec& a, const std::vector<uint32_t>& nodes, uint32_t base,
              std::vector<Eigen::Vector4f>& anchor, std::vector<bool>& pinned) {
  float w = std::isinf(a.stop) ? std::numeric_limits<float>::max() : float(a.stop);
  if (!a.keyframes.empty() && !nodes.empty()) {
    AnchorTrack track;
    for (const AnchorKeyframeSpec& key : a.keyframes) {
      track.time.push_back(key.time);
      track.offset.push_back(key.offset);
    }
    m.tracks.push_back(std::move(track));
    w = -float(m.tracks.size());
  }
  for (uint32_t k : nodes) {
    pinned[k - base] = true;
    anchor[k - base] = Eigen::Vector4f(float(a.velocity.x()), float(a.velocity.y()), float(a.velocity.z()), w);
  }
}

}  // namespace

double softNodeBound(const SoftBodySpec& s, double dx) {
  const double a = s.spacing > 0 ? s.spacing : dx;
  if (!(a > 0)) return 0.0;
  Eigen::Vector3d ext = s.size;
  if (s.isMesh()) {
    Eigen::Vector3f lo = s.mesh_data.positions[0], hi = lo;
    for (const auto& p : s.mesh_data.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    ext = (hi - lo).cast<double>();
  }
  double n = 1.0;
  for (int d = 0; d < 3; ++d) n *= std::max(1.0, std::ceil(ext[d] / a)) + 1.0;
  return n;
}


Eigen::Vector3d AnchorTrack::offsetAt(double t) const {
  if (time.empty()) return Eigen::Vector3d::Zero();
  if (t <= time.front()) return offset.front();
  if (t >= time.back()) return offset.back();
  // The segment [t_k, t_k+1) holding t: linear interpolation.
  const std::size_t k = static_cast<std::size_t>(std::upper_bound(time.begin(), time.end(), t) - time.begin()) - 1;
  const double s = (t - time[k]) / (time[k + 1] - time[k]);
  return offset[k] + s * (offset[k + 1] - offset[k]);
}

Eigen::Vector3d AnchorTrack::velocityAt(double t) const {
  if (time.size() < 2 || t < time.front() || t >= time.back()) return Eigen::Vector3d::Zero();
  const std::size_t k = static_cast<std::size_t>(std::upper_bound(time.begin(), time.end(), t) - time.begin()) - 1;
  return (offset[k + 1] - offset[k]) / (time[k + 1] - time[k]);
}

std::vector<Eigen::Vector3d> nodePositions(const ClothSpec& c) {
  // A mesh cloth: its vertices, placed like a body (x_world = position + R x_mesh).
  if (c.isMesh()) {
    const Eigen::Matrix3d R = rotation(c);
    std::vector<Eigen::Vector3d> x;
    x.reserve(c.mesh_data.positions.size());
    for (const Eigen::Vector3f& p : c.mesh_data.positions) x.push_back(c.position + R * p.cast<double>());
    return x;
  }
  const int nx = std::max(1, c.resolution_x), ny = std::max(1, c.resolution_y);
  const double sx = spacing(c.width, nx), sy = spacing(c.length, ny);
  const Eigen::Matrix3d R = rotation(c);
  std::vector<Eigen::Vector3d> x;
  x.reserve(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
  // Row by row along y, centred on the cloth origin (a single node row sits on the axis).
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const Eigen::Vector3d local(nx > 1 ? -0.5 * c.width + i * sx : 0.0, ny > 1 ? -0.5 * c.length + j * sy : 0.0, 0.0);
      x.push_back(c.position + R * local);
    }
  return x;
}

std::vector<uint32_t> anchoredNodes(const ClothSpec& c, const ClothAnchorSpec& a, const std::vector<Eigen::Vector3d>& x) {
  const int nx = std::max(1, c.resolution_x), ny = std::max(1, c.resolution_y);
  auto id = [nx](int i, int j) { return static_cast<uint32_t>(j * nx + i); };
  std::vector<uint32_t> out;
  switch (a.type) {
    case AnchorType::Corners:
      if (c.isMesh()) break;  // rectangle only (compileCloths reports it)
      for (int j : {0, ny - 1})
        for (int i : {0, nx - 1}) out.push_back(id(i, j));
      break;
    case AnchorType::Edge:
      if (c.isMesh() || a.edge == ClothEdge::ZMin || a.edge == ClothEdge::ZMax) break;  // z: a soft body's faces
      if (a.edge == ClothEdge::XMin || a.edge == ClothEdge::XMax)
        for (int j = 0; j < ny; ++j) out.push_back(id(a.edge == ClothEdge::XMin ? 0 : nx - 1, j));
      else
        for (int i = 0; i < nx; ++i) out.push_back(id(i, a.edge == ClothEdge::YMin ? 0 : ny - 1));
      break;
    case AnchorType::Node:
      if (a.k != 0) break;  // k is a soft body's lattice index
      // A mesh cloth: vertex index i.
      if (c.isMesh()) {
        if (a.i >= 0 && static_cast<std::size_t>(a.i) < x.size() && a.j == 0) out.push_back(static_cast<uint32_t>(a.i));
        break;
      }
      if (a.i >= 0 && a.i < nx && a.j >= 0 && a.j < ny) out.push_back(id(a.i, a.j));
      break;
    case AnchorType::Box:
      for (std::size_t k = 0; k < x.size(); ++k)
        if ((x[k].array() >= a.min.array()).all() && (x[k].array() <= a.max.array()).all())
          out.push_back(static_cast<uint32_t>(k));
      break;
  }
  // Corners of a chain or a single node repeat: keep each node once.
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Eigen::Vector3d softSpringStiffness(double E, double a) {
  // Central springs on a cubic cell: under a uniform strain eps the springs store
  // W = 1/2 sum k L^2 (n.eps.n)^2, i.e. the stiffness tensor C_ijkl = (1 / a^3) sum k L^2 n_i n_j n_k n_l
  // over the cell's springs. With k_e per edge (12, L = a), k_f per face diagonal (12, L = a sqrt 2)
  // and k_b per body diagonal (4, L = a sqrt 3):
  //   C11 = (4 k_e + 4 k_f + 4/3 k_b) / a,   C12 = C44 = (2 k_f + 4/3 k_b) / a  (Cauchy: central forces).
  // Isotropy (C11 - C12 = 2 C44) needs 4 k_e = 2 k_f + 8/3 k_b; the solid is then isotropic with
  // lambda = mu = C44, Poisson ratio 1/4 and E = 5/2 mu (the only isotropic solid a central-force
  // lattice gives; Ostoja-Starzewski 2002, Appl. Mech. Rev. 55(1), sec. 2). One choice is left:
  // k_f = k_b = kappa (body diagonals as stiff as face diagonals, so no cell can fold flat through
  // a diagonal plane), giving E = 25 kappa / (3 a): kappa = 0.12 E a, k_e = 7 kappa / 6 = 0.14 E a.
  // A spring shared by several cells (an edge by up to 4, a face diagonal by 2) sums their shares,
  // so a block of cells has exactly this stiffness under any uniform strain, surface cells included.
  const double kappa = 0.12 * E * a;
  return Eigen::Vector3d(7.0 / 6.0 * kappa, kappa, kappa);
}

SoftLattice softLattice(const SoftBodySpec& s, double dx) {
  SoftLattice L;
  const double a = s.spacing > 0 ? s.spacing : dx;
  if (!(a > 0)) return L;
  // The bounding grid (body frame): a box's extents in whole cells (spacing rounded per axis so
  // that the box is filled exactly), or cells of `a` over the mesh's bounds, centred on them.
  Eigen::Vector3d lo;
  std::array<int, 3>& nc = L.cells_per_axis;
  if (s.isMesh()) {
    Eigen::Vector3f mlo = s.mesh_data.positions[0], mhi = mlo;
    for (const auto& p : s.mesh_data.positions) mlo = mlo.cwiseMin(p), mhi = mhi.cwiseMax(p);
    const Eigen::Vector3d ext = (mhi - mlo).cast<double>(), centre = 0.5 * (mhi + mlo).cast<double>();
    for (int d = 0; d < 3; ++d) {
      nc[d] = std::max(1, static_cast<int>(std::ceil(ext[d] / a)));
      L.spacing[d] = a;
    }
    lo = centre - 0.5 * a * Eigen::Vector3d(nc[0], nc[1], nc[2]);
  } else {
    for (int d = 0; d < 3; ++d) {
      nc[d] = std::max(1, static_cast<int>(std::lround(s.size[d] / a)));
      L.spacing[d] = s.size[d] / nc[d];
    }
    lo = -0.5 * s.size;
  }
  // Filled cells: all of a box's; a mesh's whose centre is inside the closed surface.
  std::unique_ptr<ClosedSurface> surface;
  if (s.isMesh()) surface = std::make_unique<ClosedSurface>(s.mesh_data);
  const std::size_t nx = nc[0] + 1, ny = nc[1] + 1, nz = nc[2] + 1;
  auto node_at = [&](int i, int j, int k) { return (static_cast<std::size_t>(k) * ny + j) * nx + i; };
  std::vector<int64_t> id(nx * ny * nz, -1);
  for (int k = 0; k < nc[2]; ++k)
    for (int j = 0; j < nc[1]; ++j)
      for (int i = 0; i < nc[0]; ++i) {
        const Eigen::Vector3d centre = lo + Eigen::Vector3d((i + 0.5) * L.spacing.x(), (j + 0.5) * L.spacing.y(), (k + 0.5) * L.spacing.z());
        if (surface && !surface->inside(centre)) continue;
        L.cell_ijk.push_back({i, j, k});
        for (int c = 0; c < 8; ++c) id[node_at(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1))] = 0;
      }
  // Nodes: the filled cells' corners, numbered in lattice order (x fastest), placed in the world.
  const Eigen::Matrix3d R = rotation(s);
  for (std::size_t k = 0; k < nz; ++k)
    for (std::size_t j = 0; j < ny; ++j)
      for (std::size_t i = 0; i < nx; ++i) {
        int64_t& n = id[node_at(int(i), int(j), int(k))];
        if (n < 0) continue;
        n = static_cast<int64_t>(L.x.size());
        const Eigen::Vector3d local = lo + Eigen::Vector3d(i * L.spacing.x(), j * L.spacing.y(), k * L.spacing.z());
        L.x.push_back(s.position + R * local);
        L.node_ijk.push_back({int(i), int(j), int(k)});
      }
  for (const auto& c : L.cell_ijk) {
    std::array<uint32_t, 8> corners;
    for (int q = 0; q < 8; ++q) corners[q] = static_cast<uint32_t>(id[node_at(c[0] + (q & 1), c[1] + (q >> 1 & 1), c[2] + (q >> 2 & 1))]);
    L.cells.push_back(corners);
  }
  return L;
}

namespace {
// The nodes of a soft body that an anchor pins (indices into the lattice's nodes, ascending):
//  - box: the nodes inside min..max (world frame);
//  - edge: a face of the lattice (x_min: the nodes of the smallest lattice index i, ... z_max: the
//    largest k; body frame);
//  - corners: the lattice's eight extreme nodes, for each direction s = (+-1, +-1, +-1) the node
//    that maximises s . (i, j, k) (the first in node order on a tie): a box's eight corners; for a
//    mesh's lattice the outermost node towards each diagonal;
//  - node: the node of lattice index (i, j, k), 0 .. cells_per_axis (none where a mesh's lattice
//    has no node).
std::vector<uint32_t> softAnchoredNodes(const SoftLattice& L, const ClothAnchorSpec& a) {
  std::vector<uint32_t> out;
  if (a.type == AnchorType::Box) {
    for (std::size_t k = 0; k < L.x.size(); ++k)
      if ((L.x[k].array() >= a.min.array()).all() && (L.x[k].array() <= a.max.array()).all()) out.push_back(uint32_t(k));
  } else if (a.type == AnchorType::Edge) {
    const int axis = (a.edge == ClothEdge::XMin || a.edge == ClothEdge::XMax) ? 0
                     : (a.edge == ClothEdge::YMin || a.edge == ClothEdge::YMax) ? 1 : 2;
    const bool at_max = a.edge == ClothEdge::XMax || a.edge == ClothEdge::YMax || a.edge == ClothEdge::ZMax;
    int lo = std::numeric_limits<int>::max(), hi = std::numeric_limits<int>::min();
    for (const auto& ijk : L.node_ijk) lo = std::min(lo, ijk[axis]), hi = std::max(hi, ijk[axis]);
    for (std::size_t k = 0; k < L.node_ijk.size(); ++k)
      if (L.node_ijk[k][axis] == (at_max ? hi : lo)) out.push_back(uint32_t(k));
  } else if (a.type == AnchorType::Corners) {
    for (int c = 0; c < 8 && !L.node_ijk.empty(); ++c) {
      const int sx = (c & 1) ? 1 : -1, sy = (c & 2) ? 1 : -1, sz = (c & 4) ? 1 : -1;
      std::size_t best = 0;
      int best_v = std::numeric_limits<int>::min();
      for (std::size_t k = 0; k < L.node_ijk.size(); ++k) {
        const auto& q = L.node_ijk[k];
        const int v = sx * q[0] + sy * q[1] + sz * q[2];
        if (v > best_v) best_v = v, best = k;
      }
      out.push_back(uint32_t(best));
    }
  } else if (a.type == AnchorType::Node) {
    for (std::size_t k = 0; k < L.node_ijk.size(); ++k)
      if (L.node_ijk[k] == std::array<int, 3>{{a.i, a.j, a.k}}) out.push_back(uint32_t(k));
  }
  // A lattice one cell thick has coinciding corners: keep each node once.
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::string nodeBudgetMessage(const ClothSpec& s, int nx, int ny) {
  std::ostringstream msg;
  msg << "cloth '" << s.name << "': " << nx << " x " << ny << " nodes (with the cloths before it) is more than the "
      << kMaxNodes << " nodes supported";
  return msg.str();
}
}  // namespace

bool checkNodeBudget(const std::vector<ClothSpec>& specs, std::vector<InputIssue>& issues) {
  double total = 0;
  for (const ClothSpec& s : specs) {
    total += s.nodeCount();
    if (total > kMaxNodes) {
      issues.push_back(InputIssue{s.loc.file, s.loc.line, s.loc.col, nodeBudgetMessage(s, s.resolution_x, s.resolution_y)});
      return false;
    }
  }
  return true;
}

ClothModel compileCloths(const std::vector<ClothSpec>& specs, std::vector<InputIssue>& issues,
                         const std::vector<SoftBodySpec>& soft, double dx) {
  ClothModel m;
  auto fail = [&](const SourceLoc& loc, const std::string& msg) {
    issues.push_back(InputIssue{loc.file, loc.line, loc.col, msg});
  };
  std::vector<std::array<uint32_t, 2>> ends;
  m.explicit_dt_limit = std::numeric_limits<double>::infinity();
  m.xpbd_dt_limit = std::numeric_limits<double>::infinity();

  for (std::size_t c = 0; c < specs.size(); ++c) {
    const ClothSpec& s = specs[c];
    for (std::size_t d = 0; d < c; ++d)
      if (specs[d].name == s.name) fail(s.loc, "duplicate cloth name '" + s.name + "'");
    if (!s.isMesh() && (s.resolution_x < 1 || s.resolution_y < 1)) {
      fail(s.loc, "cloth '" + s.name + "': resolution must be at least 1 x 1 nodes");
      continue;
    }
    const int nx = s.resolution_x, ny = s.resolution_y;
    // Bounded resources: about 400 bytes of tables per node (host and device alike).
    if (s.nodeCount() + static_cast<double>(m.x0.size()) > kMaxNodes) {
      fail(s.loc, nodeBudgetMessage(s, nx, ny));
      continue;
    }
    if (s.prestrain > 0 && s.tear_strain <= s.prestrain) {
      std::ostringstream msg;
      msg << "cloth '" << s.name << "': tear_strain " << s.tear_strain << " must exceed prestrain " << s.prestrain
          << " (every spring would break at once)";
      fail(s.loc, msg.str());
    }
    const uint32_t base = static_cast<uint32_t>(m.x0.size());
    const std::vector<Eigen::Vector3d> x = nodePositions(s);
    const uint32_t n = static_cast<uint32_t>(x.size());
    m.first_node.push_back(base);
    m.num_nodes.push_back(n);
    m.first_spring.push_back(static_cast<uint32_t>(ends.size()));
    m.xpbd.push_back(s.solver == ClothSolver::Xpbd ? 1 : 0);
    m.iterations.push_back(static_cast<uint32_t>(std::max(1, s.iterations)));
    if (s.solver == ClothSolver::Xpbd && s.max_time_step > 0.0) m.xpbd_dt_limit = std::min(m.xpbd_dt_limit, s.max_time_step);

    // Nodes: equal masses (areal density x area / nodes); anchored nodes get inverse mass 0. A mesh
    // cloth: each vertex a third of the area of its triangles (lumped mass), so the masses sum to
    // areal density x the mesh's area.
    std::vector<double> node_mass(n, s.areal_density * s.width * s.length / n);
    if (s.isMesh()) {
      std::fill(node_mass.begin(), node_mass.end(), 0.0);
      for (const auto& t : s.mesh_data.triangles) {
        const double area = 0.5 * (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).norm();
        for (uint32_t v : t) node_mass[v] += s.areal_density * area / 3.0;
      }
      // A vertex in no (non-degenerate) triangle would have no mass.
      for (uint32_t k = 0; k < n; ++k)
        if (!(node_mass[k] > 0.0)) {
          fail(s.mesh_loc, "cloth '" + s.name + "': mesh vertex " + std::to_string(k) +
                               " is in no triangle of nonzero area (it would have no mass)");
          std::fill(node_mass.begin(), node_mass.end(), 1.0);
          break;
        }
    }
    std::vector<Eigen::Vector4f> anchor(n, Eigen::Vector4f::Zero());
    std::vector<bool> pinned(n, false);
    for (const ClothAnchorSpec& a : s.anchors) {
      const std::vector<uint32_t> nodes = anchoredNodes(s, a, x);
      if (nodes.empty()) {
        std::ostringstream msg;
        msg << "cloth '" << s.name << "': this anchor pins no node of the cloth";
        if (s.isMesh() && (a.type == AnchorType::Corners || a.type == AnchorType::Edge))
          msg << " (corners and edge are for the rectangle: a mesh cloth takes node (vertex i) or box anchors)";
        else if (a.type == AnchorType::Edge)
          msg << " (a cloth's edges are x_min, x_max, y_min and y_max; z_min and z_max are a soft body's faces)";
        else if (a.type == AnchorType::Node && a.k != 0)
          msg << " (k " << a.k << ": a cloth's nodes are (i, j); k is for soft bodies)";
        else if (a.type == AnchorType::Node && s.isMesh())
          msg << " (vertex " << a.i << ", j " << a.j << ": a mesh cloth has vertices 0.." << n - 1 << " and j 0)";
        else if (a.type == AnchorType::Node)
          msg << " (node (" << a.i << ", " << a.j << ") is outside 0.." << nx - 1 << " x 0.." << ny - 1 << ")";
        if (a.type == AnchorType::Box) msg << " (no node lies inside the box)";
        fail(a.loc, msg.str());
      }
      // Keyframed: the nodes point at a track (w = -(track + 1); stop times are >= 0).
      pinNodes(m, a, nodes, 0, anchor, pinned);
    }
    for (uint32_t k = 0; k < n; ++k) {
      m.x0.emplace_back(float(x[k].x()), float(x[k].y()), float(x[k].z()), pinned[k] ? 0.0f : float(1.0 / node_mass[k]));
      m.mass.push_back(float(node_mass[k]));
      m.drag.push_back(float(s.air_damping));
      m.anchor.push_back(anchor[k]);
      m.cloth_of.push_back(static_cast<uint32_t>(c));
    }

    // Springs (Provot 1995): stretch (grid neighbours), shear (both cell diagonals), bend (two apart).
    auto id = [&](int i, int j) { return base + static_cast<uint32_t>(j * nx + i); };
    const double tear = std::isinf(s.tear_strain) ? std::numeric_limits<float>::max() : s.tear_strain;
    auto add = [&](int i0, int j0, int i1, int j1, double k, SpringKind kind) {
      // Both ends on the grid (a shear spring starts at (i + 1, j), which the last column lacks).
      if (k <= 0.0 || i0 < 0 || i0 >= nx || j0 < 0 || j0 >= ny || i1 < 0 || i1 >= nx || j1 < 0 || j1 >= ny) return;
      const uint32_t a = id(i0, j0), b = id(i1, j1);
      // Placed stretched by the prestrain (skin's tension): rest length shorter than placed.
      const double L0 = (x[a - base] - x[b - base]).norm() / (1.0 + s.prestrain);
      ends.push_back({std::min(a, b), std::max(a, b)});
      m.prm.emplace_back(float(L0), float(k), float(s.damping), float(tear));
      m.kind.push_back(kind);
    };
    // A mesh cloth: stretch springs along its edges, bend springs across each interior edge
    // (between the two vertices opposite it), in the order of the edges (sorted by their ends).
    if (s.isMesh()) {
      auto addNodes = [&](uint32_t a, uint32_t b, double k, SpringKind kind) {
        if (k <= 0.0) return;
        const double L0 = (x[a] - x[b]).norm() / (1.0 + s.prestrain);
        ends.push_back({base + std::min(a, b), base + std::max(a, b)});
        m.prm.emplace_back(float(L0), float(k), float(s.damping), float(tear));
        m.kind.push_back(kind);
      };
      std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> opposite;
      for (const auto& t : s.mesh_data.triangles)
        for (int e = 0; e < 3; ++e) {
          const uint32_t a = t[e], b = t[(e + 1) % 3];
          opposite[{std::min(a, b), std::max(a, b)}].push_back(t[(e + 2) % 3]);
        }
      for (const auto& [edge, opp] : opposite) addNodes(edge.first, edge.second, s.stretch_stiffness, kStretch);
      for (const auto& [edge, opp] : opposite)
        if (opp.size() == 2 && opp[0] != opp[1]) addNodes(opp[0], opp[1], s.bend_stiffness, kBend);
    }
    for (int j = 0; j < ny && !s.isMesh(); ++j)
      for (int i = 0; i < nx; ++i) {
        add(i, j, i + 1, j, s.stretch_stiffness, kStretch);
        add(i, j, i, j + 1, s.stretch_stiffness, kStretch);
        add(i, j, i + 1, j + 1, s.shear_stiffness, kShear);
        add(i + 1, j, i, j + 1, s.shear_stiffness, kShear);
        add(i, j, i + 2, j, s.bend_stiffness, kBend);
        add(i, j, i, j + 2, s.bend_stiffness, kBend);
      }
    m.num_springs.push_back(static_cast<uint32_t>(ends.size()) - m.first_spring.back());
    m.any_tear = m.any_tear || !std::isinf(s.tear_strain);
  }

  m.num_cloths = m.first_node.size();

  // Soft bodies: lattice nodes and the springs of their cells (softSpringStiffness).
  for (std::size_t b = 0; b < soft.size(); ++b) {
    const SoftBodySpec& s = soft[b];
    const std::string label = "soft body '" + s.name + "'";
    for (std::size_t d = 0; d < b; ++d)
      if (soft[d].name == s.name) fail(s.loc, "duplicate soft body name '" + s.name + "'");
    if (s.prestrain > 0 && s.tear_strain <= s.prestrain) {
      std::ostringstream msg;
      msg << label << ": tear_strain " << s.tear_strain << " must exceed prestrain " << s.prestrain
          << " (every spring would break at once)";
      fail(s.loc, msg.str());
    }
    const double bound = softNodeBound(s, dx);
    if (bound + static_cast<double>(m.x0.size()) > kMaxNodes) {
      std::ostringstream msg;
      msg << label << ": about " << bound << " lattice nodes (with the cloths and soft bodies before it) is more than the "
          << kMaxNodes << " nodes supported (a larger spacing makes fewer)";
      fail(s.loc, msg.str());
      continue;
    }
    const SoftLattice L = softLattice(s, dx);
    if (L.cells.empty()) {
      fail(s.isMesh() ? s.mesh_loc : s.loc, label + ": no lattice cell's centre is inside the mesh (the spacing is too coarse for it)");
      continue;
    }
    const uint32_t base = static_cast<uint32_t>(m.x0.size());
    const uint32_t n = static_cast<uint32_t>(L.x.size());
    m.first_node.push_back(base);
    m.num_nodes.push_back(n);
    m.first_spring.push_back(static_cast<uint32_t>(ends.size()));
    m.xpbd.push_back(s.solver == ClothSolver::Xpbd ? 1 : 0);
    m.iterations.push_back(static_cast<uint32_t>(std::max(1, s.iterations)));
    if (s.solver == ClothSolver::Xpbd && s.max_time_step > 0.0) m.xpbd_dt_limit = std::min(m.xpbd_dt_limit, s.max_time_step);

    // Lumped masses: each cell's mass, density x volume, an eighth to each corner.
    const double cell_mass = s.density * L.spacing.prod();
    std::vector<double> node_mass(n, 0.0);
    for (const auto& cell : L.cells)
      for (uint32_t q : cell) node_mass[q] += cell_mass / 8.0;
    // Anchors: a box, a face of the lattice, its corners or one node (softAnchoredNodes), each
    // constant, moving or keyframed as for cloth.
    std::vector<Eigen::Vector4f> anchor(n, Eigen::Vector4f::Zero());
    std::vector<bool> pinned(n, false);
    for (const ClothAnchorSpec& a : s.anchors) {
      const std::vector<uint32_t> nodes = softAnchoredNodes(L, a);
      if (nodes.empty()) {
        std::ostringstream msg;
        msg << label << ": this anchor pins no node of the soft body";
        if (a.type == AnchorType::Box) msg << " (no node lies inside the box)";
        if (a.type == AnchorType::Node) {
          const auto& nc = L.cells_per_axis;
          if (a.i < 0 || a.j < 0 || a.k < 0 || a.i > nc[0] || a.j > nc[1] || a.k > nc[2])
            msg << " (node (" << a.i << ", " << a.j << ", " << a.k << ") is outside its lattice, 0.." << nc[0] << " x 0.."
                << nc[1] << " x 0.." << nc[2] << ")";
          else
            msg << " (node (" << a.i << ", " << a.j << ", " << a.k << ") is not in the lattice: no cell inside the mesh has it as a corner)";
        }
        fail(a.loc, msg.str());
      }
      pinNodes(m, a, nodes, 0, anchor, pinned);
    }
    for (uint32_t k = 0; k < n; ++k) {
      m.x0.emplace_back(float(L.x[k].x()), float(L.x[k].y()), float(L.x[k].z()), pinned[k] ? 0.0f : float(1.0 / node_mass[k]));
      m.mass.push_back(float(node_mass[k]));
      m.drag.push_back(float(s.air_damping));
      m.anchor.push_back(anchor[k]);
      m.cloth_of.push_back(static_cast<uint32_t>(m.first_node.size() - 1));
    }

    // Springs: all 28 pairs of every cell's corners, each pair's stiffness summed over the cells
    // that share it; in the order of their ends (a fixed order). Rayleigh damping: c = damping x k.
    const double a_mean = std::cbrt(L.spacing.prod());
    const Eigen::Vector3d kc = softSpringStiffness(s.young_modulus, a_mean);
    std::map<std::pair<uint32_t, uint32_t>, std::pair<double, uint32_t>> pairs;
    for (const auto& cell : L.cells)
      for (int p = 0; p < 8; ++p)
        for (int q = p + 1; q < 8; ++q) {
          const int bits = __builtin_popcount(static_cast<unsigned>(p ^ q));
          pairs[{std::min(cell[p], cell[q]), std::max(cell[p], cell[q])}].first += kc[bits - 1];
        }
    const double tear = std::isinf(s.tear_strain) ? std::numeric_limits<float>::max() : s.tear_strain;
    for (auto& [pr, kv] : pairs) {
      kv.second = static_cast<uint32_t>(ends.size());
      const Eigen::Vector3d d = L.x[pr.second] - L.x[pr.first];
      const double L0 = d.norm() / (1.0 + s.prestrain);
      ends.push_back({base + pr.first, base + pr.second});
      m.prm.emplace_back(float(L0), float(kv.first), float(s.damping * kv.first), float(tear));
      const auto &ia = L.node_ijk[pr.first], &ib = L.node_ijk[pr.second];
      const int apart = (ia[0] != ib[0]) + (ia[1] != ib[1]) + (ia[2] != ib[2]);
      m.kind.push_back(apart == 1 ? kStretch : apart == 2 ? kShear : kBodyDiagonal);
    }
    m.num_springs.push_back(static_cast<uint32_t>(ends.size()) - m.first_spring.back());
    m.any_tear = m.any_tear || !std::isinf(s.tear_strain);

    // The cells, for the surface mesh: corner nodes and their springs (global).
    ClothModel::SoftCells sc;
    sc.cells_per_axis = L.cells_per_axis;
    sc.ijk = L.cell_ijk;
    for (const auto& cell : L.cells) {
      std::array<uint32_t, 8> nodes;
      std::array<uint32_t, 28> springs;
      int e = 0;
      for (int p = 0; p < 8; ++p) {
        nodes[p] = base + cell[p];
        for (int q = p + 1; q < 8; ++q) springs[e++] = pairs.at({std::min(cell[p], cell[q]), std::max(cell[p], cell[q])}).second;
      }
      sc.nodes.push_back(nodes);
      sc.springs.push_back(springs);
    }
    m.soft.push_back(std::move(sc));
  }

  // Compressed rows: count, prefix sum, fill in spring order (a fixed order).
  const std::size_t N = m.x0.size(), S = ends.size();
  m.row_start.assign(N + 1, 0);
  for (const auto& e : ends) {
    ++m.row_start[e[0] + 1];
    ++m.row_start[e[1] + 1];
  }
  for (std::size_t i = 0; i < N; ++i) m.row_start[i + 1] += m.row_start[i];
  m.spring.assign(2 * S, 0);
  m.other.assign(2 * S, 0);
  std::vector<uint32_t> fill(m.row_start.begin(), m.row_start.end() - 1);
  for (uint32_t s = 0; s < S; ++s)
    for (int side = 0; side < 2; ++side) {
      const uint32_t i = ends[s][side], e = fill[i]++;
      m.spring[e] = s;
      m.other[e] = ends[s][1 - side];
    }
  m.ends.reserve(2 * S);
  for (const auto& e : ends) {
    m.ends.push_back(e[0]);
    m.ends.push_back(e[1]);
  }

  // Greedy edge colouring in spring order: the smallest colour free at both ends.
  std::vector<std::vector<bool>> used(N);
  std::vector<uint32_t> colour(S, 0);
  for (uint32_t s = 0; s < S; ++s) {
    const uint32_t a = ends[s][0], b = ends[s][1];
    uint32_t c = 0;
    while ((c < used[a].size() && used[a][c]) || (c < used[b].size() && used[b][c])) ++c;
    for (uint32_t i : {a, b}) {
      if (used[i].size() <= c) used[i].resize(c + 1, false);
      used[i][c] = true;
    }
    colour[s] = c;
    m.num_colours = std::max(m.num_colours, c + 1);
  }
  m.slot.assign(static_cast<std::size_t>(m.num_colours) * N, kNoSlot);
  for (uint32_t i = 0; i < N; ++i)
    for (uint32_t e = m.row_start[i]; e < m.row_start[i + 1]; ++e) m.slot[colour[m.spring[e]] * N + i] = e;

  // Explicit step limit. Gershgorin on M^-1/2 K M^-1/2 bounds omega_max^2 by the largest row sum
  // sum_j k_ij / m_i + sum_{j free} k_ij / sqrt(m_i m_j) over free nodes i (exact for one mass on
  // a spring to an anchor: k / m); the same bound on the dashpots gives the damping rate d_max.
  for (std::size_t c = 0; c < m.xpbd.size(); ++c) {
    if (m.xpbd[c] || m.num_nodes[c] == 0) continue;
    double w2 = 0.0, d = 0.0;
    for (uint32_t i = m.first_node[c]; i < m.first_node[c] + m.num_nodes[c]; ++i) {
      if (m.x0[i].w() == 0.0f) continue;
      double rk = 0.0, rc = 0.0;
      for (uint32_t e = m.row_start[i]; e < m.row_start[i + 1]; ++e) {
        const Eigen::Vector4f& p = m.prm[m.spring[e]];
        const uint32_t j = m.other[e];
        const double mi = m.mass[i], mj = m.mass[j];
        const double f = 1.0 / mi + (m.x0[j].w() > 0.0f ? 1.0 / std::sqrt(mi * mj) : 0.0);
        rk += p.y() * f;
        rc += p.z() * f;
      }
      w2 = std::max(w2, rk);
      d = std::max(d, rc + m.drag[i]);
    }
    if (w2 <= 0.0) continue;
    const double w = std::sqrt(w2), xi = d / (2.0 * w);
    // Belytschko et al. 2000, eq. 6.3.38 (central differences with damping), with a 10 % margin.
    m.explicit_dt_limit = std::min(m.explicit_dt_limit, 0.9 * 2.0 / w * (std::sqrt(1.0 + xi * xi) - xi));
  }
  return m;
}

// --- Device state ------------------------------------------------------------------------------

cl::Buffer ClothSim::make(std::size_t bytes) {
  bytes = std::max<std::size_t>(bytes, 16);
  bytes_ += bytes;
  return clCall("allocating a cloth buffer", [&] { return cl::Buffer(cl_.context(), CL_MEM_READ_WRITE, bytes); });
}

template <class T>
cl::Buffer ClothSim::upload(const std::vector<T>& data) {
  cl::Buffer b = make(data.size() * sizeof(T));
  if (!data.empty())
    clCall("uploading the cloth", [&] { return cl_.queue().enqueueWriteBuffer(b, CL_TRUE, 0, data.size() * sizeof(T), data.data()); });
  return b;
}

ClothSim::ClothSim(const ClothModel& model, ClContext& cl, KernelSet& kernels) : m_(model), cl_(cl), k_(kernels) {
  n_ = static_cast<uint32_t>(m_.nodes());
  ns_ = static_cast<uint32_t>(m_.springs());
  for (uint8_t x : m_.xpbd) (x ? any_xpbd_ : any_explicit_) = true;
  // Nodes at rest at their initial positions; anchored nodes carry their motion.
  x_[0] = upload(m_.x0);
  x_[1] = upload(m_.x0);
  std::vector<Eigen::Vector4f> v0(n_, Eigen::Vector4f::Zero());
  v_[0] = upload(v0);
  v_[1] = upload(v0);
  xlo_[0] = upload(v0);
  xlo_[1] = upload(v0);
  prev_ = upload(m_.x0);
  zero_force_ = upload(v0);
  impulse_M_ = upload(v0);
  vstart_ = upload(v0);
  fict_ = upload(std::vector<float>(n_, 0.0f));
  mass_ = upload(m_.mass);
  drag_ = upload(m_.drag);
  anchor_ = upload(m_.anchor);
  // Keyframed anchors: placed positions and one (offset, velocity) pair per track (at least one
  // entry, so that the kernels always get a buffer).
  x_rest_ = upload(m_.x0);
  track_host_.assign(2 * std::max<std::size_t>(1, m_.tracks.size()), Eigen::Vector4f::Zero());
  track_ = upload(track_host_);
  std::vector<uint32_t> is_xpbd(n_);
  for (uint32_t i = 0; i < n_; ++i) is_xpbd[i] = m_.xpbd[m_.cloth_of[i]];
  is_xpbd_ = upload(is_xpbd);
  // XPBD sweeps per node (its cloth's iterations); the dispatch loop runs the largest count.
  std::vector<uint32_t> iters(n_);
  for (uint32_t i = 0; i < n_; ++i) iters[i] = m_.iterations[m_.cloth_of[i]];
  for (std::size_t c = 0; c < m_.xpbd.size(); ++c)
    if (m_.xpbd[c]) max_iterations_ = std::max(max_iterations_, m_.iterations[c]);
  iters_ = upload(iters);
  // The spring table, the colours and the per-entry Lagrange multipliers (XPBD).
  row_start_ = upload(m_.row_start);
  spring_ = upload(m_.spring);
  other_ = upload(m_.other);
  ends_ = upload(m_.ends);
  prm_ = upload(m_.prm);
  broken_ = upload(std::vector<uint32_t>(ns_, 0u));
  slot_ = upload(m_.slot);
  lambda_ = upload(std::vector<float>(m_.spring.size(), 0.0f));
  // The fused XPBD solve's work-group: as large as the device allows for it, at most 256.
  fused_local_ = std::min<std::size_t>(256, clCall("querying the cloth solve's work-group size", [&] {
    return k_["cloth_xpbd_solve"].getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(cl_.device());
  }));
}

void ClothSim::uploadSpheres(const std::vector<SphereCollider>& spheres) {
  const uint32_t ns = static_cast<uint32_t>(spheres.size());
  if (sphere_capacity_ < ns) {
    spheres_ = make(ns * 32);
    impulse_ = make(static_cast<std::size_t>(ns) * n_ * 16);
    shift_ = make(static_cast<std::size_t>(ns) * n_ * 16);
    impulse_sum_ = make(ns * 16);
    sphere_capacity_ = ns;
  }
  // Per sphere: (centre, radius), (velocity, friction).
  std::vector<Eigen::Vector4f> data;
  for (const SphereCollider& sp : spheres) {
    data.emplace_back(float(sp.centre.x()), float(sp.centre.y()), float(sp.centre.z()), float(sp.radius));
    data.emplace_back(float(sp.velocity.x()), float(sp.velocity.y()), float(sp.velocity.z()), float(sp.friction));
  }
  clCall("uploading the spheres", [&] { return cl_.queue().enqueueWriteBuffer(spheres_, CL_TRUE, 0, data.size() * 16, data.data()); });
}

std::vector<Eigen::Vector3d> ClothSim::step(double t, double dt, const Eigen::Vector3d& g, const cl::Buffer* external,
                                            const std::vector<SphereCollider>& spheres) {
  const Eigen::Vector4f g4(float(g.x()), float(g.y()), float(g.z()), 0.0f);
  const cl::Buffer& fext = external ? *external : zero_force_;
  const uint32_t ns = static_cast<uint32_t>(spheres.size());
  std::vector<Eigen::Vector3d> J(ns, Eigen::Vector3d::Zero());
  if (ns > 0) uploadSpheres(spheres);
  // Explicit cloths: as many substeps as the stability limit asks for.
  last_substeps_ = 0;
  if (any_explicit_) {
    last_substeps_ = std::max(1, static_cast<int>(std::ceil(dt / m_.explicit_dt_limit * (1.0 - 1e-12))));
    const double h = dt / last_substeps_;
    for (int k = 0; k < last_substeps_; ++k) explicitSubstep(t + k * h, float(h), g4, fext);
  }
  // XPBD cloths: equal substeps of at most xpbd_dt_limit (cloth[].max_time_step), each `iterations`
  // coloured Gauss-Seidel sweeps, the step's external force (the fluid's) and gravity in each. A
  // fixed number of sweeps holds stiff springs less the longer the step, and a heavy ball pushes
  // through light nodes: substeps rather than more sweeps (Macklin et al. 2019, "Small steps in
  // physics simulation"). Balls: each substep's projections add to their impulses.
  last_xpbd_substeps_ = 0;
  // DFSPH's added mass of wet nodes (setAddedMass): the step's velocities kept for its impulse.
  const bool added_mass = added_mass_ && !dry_;
  if (added_mass)
    clCall("keeping the nodes' velocities", [&] { return cl_.queue().enqueueCopyBuffer(v_[cur_], vstart_, 0, 0, std::size_t(n_) * 16); });
  if (any_xpbd_) {
    const int k = xpbdSubsteps(dt);
    const double h = dt / k;
    last_xpbd_substeps_ = k;
    last_dt_ = h;
    for (int j = 0; j < k; ++j) {
      uploadTracks(t + (j + 1) * h);
      xpbdStep(t + j * h, float(h), g4, fext, ns);
      if (ns > 0 && !dry_) {
        k_.call("cloth_sphere_shift_reduce", ns, 0, n_, ns, float(h), mass_, drag_, fict_, shift_, impulse_sum_);
        std::vector<Eigen::Vector4f> sums(ns);
        clCall("reading the sphere impulses", [&] { return cl_.queue().enqueueReadBuffer(impulse_sum_, CL_TRUE, 0, ns * 16, sums.data()); });
        for (uint32_t q = 0; q < ns; ++q) J[q] += sums[q].head<3>().cast<double>();
      }
    }
  }
  // The domain's closed walls (the fluid's boundary particles do not push the nodes).
  if (m_.closed_mask != 0) {
    const cl_float4 lo{{m_.walls_min.x(), m_.walls_min.y(), m_.walls_min.z(), 0.0f}};
    const cl_float4 hi{{m_.walls_max.x(), m_.walls_max.y(), m_.walls_max.z(), 0.0f}};
    k_.call("cloth_domain_walls", n_, 64, n_, lo, hi, m_.closed_mask, m_.wall_margin, x_[cur_], v_[cur_], xlo_[lo_cur_]);
  }
  if (m_.any_tear && !dry_) tear();
  if (added_mass) k_.call("cloth_added_mass_impulse", n_, 64, n_, fict_, v_[cur_], vstart_, impulse_M_);
  if (ns == 0 || dry_) return J;
  // Balls: the XPBD nodes' projections (J = -sum m dx / dt, in node order), then the explicit
  // nodes' velocity contact.
  if (any_explicit_) {
    const std::vector<Eigen::Vector3d> Je = collideSpheres(spheres);
    for (uint32_t k = 0; k < ns; ++k) J[k] += Je[k];
  }
  return J;
}

// Keyframed anchors at the end of a step: offset and velocity per track (double on the host, in
// scene order), uploaded before the step's kernels (blocking: the host copy is reused).
void ClothSim::uploadTracks(double t_end) {
  if (m_.tracks.empty()) return;
  for (std::size_t k = 0; k < m_.tracks.size(); ++k) {
    const Eigen::Vector3f o = m_.tracks[k].offsetAt(t_end).cast<float>(), v = m_.tracks[k].velocityAt(t_end).cast<float>();
    track_host_[2 * k] = Eigen::Vector4f(o.x(), o.y(), o.z(), 0.0f);
    track_host_[2 * k + 1] = Eigen::Vector4f(v.x(), v.y(), v.z(), 0.0f);
  }
  clCall("uploading the anchor tracks", [&] {
    return cl_.queue().enqueueWriteBuffer(track_, CL_TRUE, 0, track_host_.size() * 16, track_host_.data());
  });
}

void ClothSim::explicitSubstep(double t, float dt, const Eigen::Vector4f& g, const cl::Buffer& fext) {
  const int nxt = 1 - cur_;
  uploadTracks(t + dt);
  const cl_float4 g4{{g.x(), g.y(), g.z(), 0.0f}};
  k_.call("cloth_explicit_step", n_, 64, n_, dt, float(t), g4, x_[cur_], xlo_[lo_cur_], v_[cur_], mass_, drag_, anchor_,
          x_rest_, track_, is_xpbd_, row_start_, spring_, other_, prm_, broken_, fext, x_[nxt], xlo_[1 - lo_cur_], v_[nxt]);
  // XPBD nodes were copied through unchanged: both halves stay whole.
  cur_ = nxt;
  lo_cur_ = 1 - lo_cur_;
}

void ClothSim::xpbdStep(double t, float dt, const Eigen::Vector4f& g, const cl::Buffer& fext, uint32_t n_spheres) {
  const cl_float4 g4{{g.x(), g.y(), g.z(), 0.0f}};
  // Predict x* = x + dt (v + dt (g + f/m)) / (1 + dt c), remember x, clear the multipliers; the
  // solve acts on the effective inverse mass 1 / (m (1 + dt c)) (implicit drag, cloth.cl).
  k_.call("cloth_xpbd_predict", n_, 64, n_, dt, float(t), g4, x_[cur_], v_[cur_], mass_, drag_, anchor_, x_rest_,
          track_, is_xpbd_, row_start_, fext, fict_, prev_, lambda_);
  // Coloured Gauss-Seidel: per colour one gather pass, ping-ponging the positions.
  // Balls: the projections of this step add up per node and sphere (shift), from zero.
  if (n_spheres > 0)
    clCall("clearing the sphere shifts", [&] {
      return cl_.queue().enqueueFillBuffer(shift_, cl_float4{}, 0, std::size_t(n_spheres) * n_ * 16);
    });
  // Small cloths: every sweep and colour in one launch (one work-group, barriers between the
  // passes; bitwise equal to the launches below, which it replaces).
  if (n_ <= fused_max_nodes_) {
    const cl::Buffer& sph = n_spheres > 0 ? spheres_ : zero_force_;
    const cl::Buffer& shift = n_spheres > 0 ? shift_ : zero_force_;
    k_.call("cloth_xpbd_solve", fused_local_, fused_local_, n_, dt, max_iterations_, m_.num_colours, n_spheres, x_[cur_],
            x_[1 - cur_], prev_, is_xpbd_, iters_, slot_, spring_, other_, prm_, broken_, lambda_, sph, shift);
    if ((max_iterations_ * m_.num_colours) % 2 == 1) cur_ = 1 - cur_;
  }
  for (uint32_t it = 0; it < max_iterations_ && n_ > fused_max_nodes_; ++it) {
    for (uint32_t c = 0; c < m_.num_colours; ++c) {
      const int nxt = 1 - cur_;
      k_.call("cloth_xpbd_colour", n_, 64, n_, dt, it, c, x_[cur_], prev_, is_xpbd_, iters_,
              slot_ , spring_, other_, prm_, broken_, lambda_, x_[nxt]);
      cur_ = nxt;
    }
    // Balls are obstacles inside the solve: each sweep ends with the nodes outside them.
    if (n_spheres > 0) k_.call("cloth_sphere_project", n_, 64, n_, n_spheres, spheres_, is_xpbd_, x_[cur_], shift_);
  }
  // Velocities from the positions (anchored nodes: their scripted velocity).
  k_.call("cloth_xpbd_velocity", n_, 64, n_, dt, float(t), x_[cur_], prev_, anchor_, track_, is_xpbd_, v_[cur_]);
}

std::vector<Eigen::Vector3d> ClothSim::collideSpheres(const std::vector<SphereCollider>& spheres) {
  const uint32_t ns = static_cast<uint32_t>(spheres.size());
  std::vector<Eigen::Vector3d> out(ns, Eigen::Vector3d::Zero());
  if (ns == 0 || n_ == 0) return out;
  uploadSpheres(spheres);
  k_.call("cloth_sphere_contact", n_, 64, n_, ns, spheres_, mass_, is_xpbd_, x_[cur_], v_[cur_], impulse_, xlo_[lo_cur_]);
  k_.call("cloth_sphere_reduce", ns, 0, n_, ns, impulse_, impulse_sum_);
  std::vector<Eigen::Vector4f> sums(ns);
  clCall("reading the sphere impulses", [&] { return cl_.queue().enqueueReadBuffer(impulse_sum_, CL_TRUE, 0, ns * 16, sums.data()); });
  for (uint32_t k = 0; k < ns; ++k) out[k] = sums[k].head<3>().cast<double>();
  return out;
}

Eigen::Vector3d ClothSim::pendingAddedMassMomentum() {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  if (!added_mass_ || n_ == 0) return sum;
  std::vector<Eigen::Vector4f> J(n_);
  clCall("reading the added-mass impulses", [&] { return cl_.queue().enqueueReadBuffer(impulse_M_, CL_TRUE, 0, std::size_t(n_) * 16, J.data()); });
  for (const Eigen::Vector4f& j : J) sum += j.head<3>().cast<double>();
  return sum;
}

int ClothSim::xpbdSubsteps(double dt) const {
  return any_xpbd_ ? std::max(1, static_cast<int>(std::ceil(dt / m_.xpbd_dt_limit * (1.0 - 1e-12)))) : 0;
}

void ClothSim::nodeResponse(double dt, cl::Buffer& out) {
  k_.call("cloth_node_response", n_, 64, n_, float(dt), x_[cur_], mass_, drag_, row_start_, spring_, other_, prm_, broken_, fict_, out);
}

void ClothSim::dryVelocityChange(double t, double dt, const Eigen::Vector3d& g,
                                 const std::vector<SphereCollider>& spheres, cl::Buffer& out) {
  if (n_ == 0) return;
  const std::size_t bytes = std::size_t(n_) * 16;
  if (!dry_x_()) dry_x_ = make(bytes), dry_v_ = make(bytes), dry_lo_ = make(bytes);
  const int cur = cur_, lo_cur = lo_cur_, substeps = last_substeps_, xpbd_substeps = last_xpbd_substeps_;
  const double last_dt = last_dt_;
  auto copy = [&](const cl::Buffer& from, cl::Buffer& to) {
    clCall("keeping the cloth over a dry step", [&] { return cl_.queue().enqueueCopyBuffer(from, to, 0, 0, bytes); });
  };
  copy(x_[cur], dry_x_);
  copy(v_[cur], dry_v_);
  copy(xlo_[lo_cur], dry_lo_);
  dry_ = true;
  step(t, dt, g, nullptr, spheres);
  dry_ = false;
  k_.call("cloth_velocity_change", n_, 64, n_, v_[cur_], dry_v_, out);
  cur_ = cur, lo_cur_ = lo_cur, last_substeps_ = substeps, last_xpbd_substeps_ = xpbd_substeps, last_dt_ = last_dt;
  copy(dry_x_, x_[cur]);
  copy(dry_v_, v_[cur]);
  copy(dry_lo_, xlo_[lo_cur]);
}

void ClothSim::setCutters(const std::vector<const TriMesh*>& meshes) {
  // All cutters' triangles in one buffer, each cutter a range of it.
  std::vector<Eigen::Vector4f> tri;
  std::vector<uint32_t> range;
  for (const TriMesh* m : meshes) {
    range.push_back(static_cast<uint32_t>(tri.size() / 3));
    range.push_back(static_cast<uint32_t>(m->numTriangles()));
    for (const auto& t : m->triangles)
      for (uint32_t v : t) tri.emplace_back(m->positions[v].x(), m->positions[v].y(), m->positions[v].z(), 0.0f);
  }
  n_cutters_ = static_cast<uint32_t>(meshes.size());
  if (n_cutters_ == 0) return;
  cut_tri_ = upload(tri);
  cut_range_ = upload(range);
  cut_pose_ = make(std::size_t(n_cutters_) * 4 * 16);
}

void ClothSim::cut(const std::vector<CutterPose>& poses) {
  SPH_ASSERT(poses.size() == n_cutters_, "one pose per cutter");
  if (n_cutters_ == 0 || ns_ == 0) return;
  // Per cutter: the rows of R^T (world -> body) and the centre.
  std::vector<Eigen::Vector4f> pose;
  for (const CutterPose& p : poses) {
    const Eigen::Matrix3f Rt = p.q.toRotationMatrix().transpose().cast<float>();
    for (int r = 0; r < 3; ++r) pose.emplace_back(Rt(r, 0), Rt(r, 1), Rt(r, 2), 0.0f);
    pose.emplace_back(float(p.centre.x()), float(p.centre.y()), float(p.centre.z()), 0.0f);
  }
  clCall("uploading the cutter poses", [&] { return cl_.queue().enqueueWriteBuffer(cut_pose_, CL_TRUE, 0, pose.size() * 16, pose.data()); });
  k_.call("cloth_cut", ns_, 64, ns_, n_cutters_, x_[cur_], ends_, cut_pose_, cut_range_, cut_tri_, broken_);
}

void ClothSim::tear() {
  k_.call("cloth_tear", ns_, 64, ns_, x_[cur_], ends_, prm_, broken_);
}

void ClothSim::read(std::vector<Eigen::Vector4f>& x, std::vector<Eigen::Vector4f>& v) {
  x.resize(n_);
  v.resize(n_);
  if (n_ == 0) return;
  clCall("reading the cloth", [&] {
    cl_.queue().enqueueReadBuffer(x_[cur_], CL_TRUE, 0, n_ * 16, x.data());
    cl_.queue().enqueueReadBuffer(v_[cur_], CL_TRUE, 0, n_ * 16, v.data());
    return 0;
  });
}

void ClothSim::write(const std::vector<Eigen::Vector4f>& x, const std::vector<Eigen::Vector4f>& v) {
  SPH_ASSERT(x.size() == n_ && v.size() == n_, "one position and velocity per node");
  if (n_ == 0) return;
  clCall("writing the cloth", [&] {
    cl_.queue().enqueueWriteBuffer(x_[cur_], CL_TRUE, 0, n_ * 16, x.data());
    cl_.queue().enqueueWriteBuffer(v_[cur_], CL_TRUE, 0, n_ * 16, v.data());
    // The positions written are whole: no low parts (explicit solver).
    cl_.queue().enqueueFillBuffer(xlo_[lo_cur_], cl_float4{}, 0, n_ * 16);
    return 0;
  });
}

std::vector<uint32_t> ClothSim::readBroken() {
  std::vector<uint32_t> b(ns_, 0);
  if (ns_ > 0)
    clCall("reading broken springs", [&] { return cl_.queue().enqueueReadBuffer(broken_, CL_TRUE, 0, ns_ * 4, b.data()); });
  return b;
}

ClothReport ClothSim::report(std::size_t c, const Eigen::Vector3d& g) {
  std::vector<Eigen::Vector4f> x, v;
  read(x, v);
  const std::vector<uint32_t> broken = readBroken();
  // XPBD: the spring force is the constraint force lambda / dt^2 of the last step (Macklin 2016,
  // eq. 9 and 11), not k (L - L0): an unconverged solve leaves L - L0 larger than the force says.
  const bool xpbd = m_.xpbd[c] && last_dt_ > 0;
  std::vector<float> lambda;
  if (xpbd) {
    lambda.resize(m_.spring.size());
    clCall("reading the cloth multipliers",
           [&] { return cl_.queue().enqueueReadBuffer(lambda_, CL_TRUE, 0, lambda.size() * 4, lambda.data()); });
  }
  ClothReport r;
  // Nodes: kinetic energy and gravity (free nodes; anchored ones are driven).
  for (uint32_t i = m_.first_node[c]; i < m_.first_node[c] + m_.num_nodes[c]; ++i) {
    if (m_.x0[i].w() == 0.0f) continue;
    const double mi = m_.mass[i];
    r.kinetic += 0.5 * mi * v[i].head<3>().cast<double>().squaredNorm();
    r.potential -= mi * g.dot(x[i].head<3>().cast<double>());
  }
  // Springs in order: elastic energy, strain, and their pull on the anchored ends.
  for (uint32_t s = m_.first_spring[c]; s < m_.first_spring[c] + m_.num_springs[c]; ++s) {
    if (broken[s]) {
      ++r.broken;
      continue;
    }
    const uint32_t a = m_.ends[2 * s], b = m_.ends[2 * s + 1];
    const Eigen::Vector3d d = (x[b].head<3>() - x[a].head<3>()).cast<double>();
    const double L = d.norm(), L0 = m_.prm[s].x(), k = m_.prm[s].y();
    if (L0 > 0) r.max_strain = std::max(r.max_strain, (L - L0) / L0);
    // Tension T (positive when stretched): explicit k (L - L0); XPBD -lambda / dt^2, lambda from
    // a's row (both rows hold the same value).
    double T = k * (L - L0);
    if (xpbd) {
      for (uint32_t e = m_.row_start[a]; e < m_.row_start[a + 1]; ++e)
        if (m_.spring[e] == s) T = -static_cast<double>(lambda[e]) / (last_dt_ * last_dt_);
    }
    r.elastic += 0.5 * T * T / k;
    const Eigen::Vector3d f = L > 0 ? Eigen::Vector3d(T * d / L) : Eigen::Vector3d::Zero();  // on a, towards b
    if (m_.x0[a].w() == 0.0f) r.anchor_force += f;
    if (m_.x0[b].w() == 0.0f) r.anchor_force -= f;
  }
  return r;
}

}  // namespace sph::cloth
