#include "core/model.h"

#include "core/errors.h"
#include "core/implicit_viscosity.h"
#include "core/mesh_distance.h"
#include "kernels/shared/sph_kernel.h"

#include <Eigen/Geometry>

#include <unistd.h>

#include <algorithm>
#include <memory>
#include <array>
#include <map>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <unordered_map>

namespace sph {

namespace {
// Verlet-list skin as a share of the support H (the lists hold neighbours within H + skin and are
// rebuilt when some particle may have moved skin / 2). WCSPH's steps (dt ~ 0.1 ms, bound by the
// speed of sound) move a particle ~0.02 dx, so a quarter of H lasts ~25 steps. A DFSPH step at
// CFL 0.4 moves the fastest particle ~0.4 dx, more than half of any skin worth having, so in a
// flowing scene the lists are rebuilt every step whatever the skin, and every build and density
// pass costs more with it: the cells are H + skin wide (the build scans 27 of them) and the density
// pass filters the (1 + skin / H)^3 longer lists. Measured (50k dam break, 0.52 s, process CPU of
// the build per build, loaded machine): skin H/10 17.4 ms, H/20 15.9, H/40 15.4, 0 14.2 ms; the
// skin H/4 (WCSPH's) was 6 % dearer per step than H/10. A skin H/40 keeps most of that saving
// (kernels' CPU per step ~3 % below H/10's) while a fluid at rest (speeds ~1 cm/s, dt 5 ms) still
// keeps its lists ~10 steps: with skin 0 every step rebuilds them (a 60k layer settling on the
// floor, 0.5 s, 104 steps: lists built 104 times, 8 % more CPU per step than with H/10's 8
// builds; with H/40 26 builds, ~3 ms more per step in the build, ~2 %).
double skinRatio(const FluidSpec& fl) { return fl.solver == FluidSolver::Dfsph ? 0.025 : 0.25; }
}  // namespace

static_assert(sizeof(SimParams) % 4 == 0, "SimParams holds 4-byte scalars only");
static_assert(sizeof(SimParams) == 4 * (4 + 4 + 4 + 4 + 4 + 10 + 1 + 4 + 4 + 3 * SPH_MAX_PHASES),
              "SimParams layout must match kernels/shared/sim_params.h on the device");

void HostParticles::push(const Eigen::Vector3f& x, const Eigen::Vector3f& v, const Eigen::Vector3f& c, uint32_t ph,
                         uint32_t i) {
  pos.emplace_back(x.x(), x.y(), x.z(), 0.0f);
  vel.emplace_back(v.x(), v.y(), v.z(), 0.0f);
  colour.emplace_back(c.x(), c.y(), c.z(), 1.0f);
  phase.push_back(ph);
  id.push_back(i);
}

double smoothRamp(double t, double duration) {
  if (duration <= 0.0 || t >= duration) return 1.0;
  // Smooth ramp (zero slope at both ends), as in Adami et al. 2012's hydrostatic tank.
  return 0.5 * (std::sin((t / duration - 0.5) * M_PI) + 1.0);
}

Eigen::Vector3d gravityAt(const SimulationSpec& sim, double t) {
  if (sim.gravity_ramp <= 0.0 || t >= sim.gravity_ramp) return sim.gravity;
  return smoothRamp(t, sim.gravity_ramp) * sim.gravity;
}

namespace {

// A simple hash grid on the host, for set-up work (boundary volumes).
struct HostGrid {
  float cell;
  std::unordered_map<int64_t, std::vector<uint32_t>> cells;
  static int64_t key(int x, int y, int z) {
    return (static_cast<int64_t>(x) + (1 << 20)) | ((static_cast<int64_t>(y) + (1 << 20)) << 21) |
           ((static_cast<int64_t>(z) + (1 << 20)) << 42);
  }
  Eigen::Vector3i coord(const Eigen::Vector3f& p) const {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / cell)), static_cast<int>(std::floor(p.y() / cell)),
                           static_cast<int>(std::floor(p.z() / cell)));
  }
};

// Lattice coordinates along one axis: `layers` outside the low wall, the interior, `layers` outside the high wall.
std::vector<double> axisLattice(double lo, double hi, double dx, int layers) {
  std::vector<double> v;
  for (int k = layers - 1; k >= 0; --k) v.push_back(lo - (k + 0.5) * dx);
  for (double x = lo + 0.5 * dx; x < hi; x += dx) v.push_back(x);
  for (int k = 0; k < layers; ++k) v.push_back(hi + (k + 0.5) * dx);
  return v;
}

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// The closed walls on the particle lattice. A block holds whole lattice cells only, so where a
// tank's size is not a multiple of dx a block that fills it stops short of the far wall, and the
// fluid falls into that gap as the run starts: a 0.2 m tank at dx = 7.5 mm (26 layers) left 5 mm
// at two walls: the hydrostatic tank's column fell 2.4-2.8 mm with either solver, and a 0.28 m
// DFSPH column ~5 mm in its first 0.15 s, then bounced (docs/dfsph.md "Session 13: gaps at the
// walls"). So each closed max wall is moved out to the next whole number of spacings from the min
// wall (less than one spacing; never in, so that whatever the scene put inside stays inside; the
// boundary lattice is then regular up to the corners), blocks that reached the wall reach it
// still, and a block that ends on a closed wall but starts inside the tank is laid from that wall
// (below).
void snapWallsToLattice(SceneSpec& s, double dx, std::vector<std::string>& notes) {
  static const char* axis_name[3] = {"x", "y", "z"};
  DomainSpec& dom = s.domain;
  for (int a = 0; a < 3; ++a) {
    if (!dom.closed[static_cast<std::size_t>(2 * a + 1)]) continue;
    const double size = dom.max[a] - dom.min[a];
    const double n = std::max(1.0, std::ceil(size / dx - 1e-3));
    const double snapped = dom.min[a] + n * dx;
    if (std::abs(snapped - dom.max[a]) <= 1e-3 * dx) continue;  // a whole number up to rounding: unchanged
    for (BlockSpec& b : s.fluid.blocks)
      if (std::abs(b.max[a] - dom.max[a]) <= 1e-3 * dx) b.max[a] = snapped;
    std::ostringstream w;
    w.precision(6);
    w << dom.loc.str() << ": the closed wall at " << axis_name[a] << " = " << dom.max[a] << " m is "
      << size / dx << " particle spacings (" << dx << " m) from the wall at " << dom.min[a]
      << " m; it is moved out to " << snapped << " m (" << n
      << " spacings), and blocks that reached it fill to it (a tank that is not a whole number of "
         "spacings would leave a gap the fluid falls into at the start)";
    notes.push_back(w.str());
    dom.max[a] = snapped;
  }
}

}  // namespace

std::vector<float> akinciVolumes(const std::vector<Eigen::Vector3f>& points, float support, int kernel) {
  HostGrid grid{support, {}};
  for (uint32_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3i c = grid.coord(points[i]);
    grid.cells[HostGrid::key(c.x(), c.y(), c.z())].push_back(i);
  }
  std::vector<float> volume(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3i c = grid.coord(points[i]);
    double sum = 0.0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          auto it = grid.cells.find(HostGrid::key(c.x() + dx, c.y() + dy, c.z() + dz));
          if (it == grid.cells.end()) continue;
          for (uint32_t j : it->second) sum += sph_w(kernel, (points[i] - points[j]).norm(), support);
        }
    volume[i] = static_cast<float>(1.0 / sum);
  }
  return volume;
}

double bodyVolumeScale(double dx, double support, int kernel) {
  // A flat face of a box, sampled and inset as compile() does for bodies; probes dx/2 above its
  // middle 8 dx x 8 dx (a support away from the edges), on a grid incommensurate with dx.
  const double side = 2.0 * (support + 5.0 * dx);
  const TriMesh box = rigid::boxMesh(Eigen::Vector3d(side, side, 2.0 * support));
  std::vector<Eigen::Vector3f> normals;
  std::vector<Eigen::Vector3f> pts = rigid::sampleSurface(box, dx, &normals);
  for (std::size_t i = 0; i < pts.size(); ++i) pts[i] -= 0.5f * static_cast<float>(dx) * normals[i];
  const std::vector<float> vol = akinciVolumes(pts, static_cast<float>(support), kernel);
  const double top = support;  // the top face's height
  double body = 0.0, lattice = 0.0;
  for (int a = -9; a <= 9; ++a)
    for (int b = -9; b <= 9; ++b) {
      const Eigen::Vector3d q(a * 0.437 * dx, b * 0.419 * dx, top + 0.5 * dx);
      for (std::size_t i = 0; i < pts.size(); ++i)
        body += vol[i] * sph_w(kernel, static_cast<float>((q - pts[i].cast<double>()).norm()), static_cast<float>(support));
      // the domain wall: a complete lattice of volume dx^3 below the face, layers at dx/2, 3dx/2, ...
      const int reach = static_cast<int>(std::ceil(support / dx)) + 1;
      for (int k = 0; k <= reach; ++k)
        for (int i = -reach; i <= reach; ++i)
          for (int j = -reach; j <= reach; ++j) {
            const Eigen::Vector3d x(std::round(q.x() / dx) * dx + i * dx, std::round(q.y() / dx) * dx + j * dx,
                                    top - (k + 0.5) * dx);
            lattice += dx * dx * dx * sph_w(kernel, static_cast<float>((q - x).norm()), static_cast<float>(support));
          }
    }
  return lattice / body;
}

// ---------------------------------------------------------------------------------------------
// Resource estimate: particles, memory and steps from the keys alone, before anything is allocated
// ---------------------------------------------------------------------------------------------

namespace {

// Bytes per item, host and device together (measured with Simulation::deviceBytes() on pocl and
// rounded up; README "Bounded resources" gives the measurement).
constexpr double kBytesPerFluidParticle = 3000;  ///< buffers, 4 neighbour lists, host copies (unit: bytes)
constexpr double kBytesPerBoundaryParticle = 64;  ///< lattice point, volume, cell sort (unit: bytes)
constexpr double kBytesPerBodyArea = 500;         ///< per dx^2 of body surface: particles + mesh (unit: bytes)
/// Per cloth node: device state (positions and velocities twice, previous positions, mass, drag,
/// anchor, flags: ~130), its ~12 spring-row entries with multipliers (~150) and ~6 springs (~200),
/// colour slots (~50), its boundary-particle copy (~80), and the host's model tables (~400).
constexpr double kBytesPerClothNode = 1000;       ///< (unit: bytes)
constexpr double kBytesPerGridCell = 16;          ///< cell start tables, host and device (unit: bytes)
/// DFSPH's extrapolated walls, per boundary particle (walls, bodies, cloth nodes): both solves'
/// wall pressures (8), the step's 32 listed fluid neighbours and their weights (256), the count,
/// the active index (8) and the pressure-free sums (16): 288 (core/dfsph.cpp), rounded up.
constexpr double kBytesPerDfsphWallParticle = 300;  ///< (unit: bytes)
/// DFSPH's two-level solve (fluid.dfsph.coarse_interval > 0, the default since session 11; on the device),
/// per fluid particle: the pair sums (27 x 2 float4, 864), their masks (8) and seven more values
/// (28), and per aggregate (at most one per 4 particles) K's 125-slot row and columns (1,000) and
/// the CG vectors (24): 1,156 (core/dfsph.cpp), rounded up; and per cell of H of the domain box
/// (the aggregate cells: at most (1 + skin / H)^3 = 1.331 per neighbour-grid cell) three values
/// (12), rounded up (16).
constexpr double kBytesPerDfsphCoarseParticle = 1300;  ///< (unit: bytes)
constexpr double kBytesPerDfsphCoarseGridCell = 1.34 * 16;  ///< (unit: bytes)
/// Candidate points rigid::sampleSurface may test for one body (~20 s on one core). (unit: 1)
constexpr double kMaxSurfaceCandidates = 4.0e8;

/// Surface area of a body's shape, scaled (unit: m^2).
double bodyArea(const RigidBodySpec& b) {
  const double r = b.radius, s2 = b.scale * b.scale;
  switch (b.shape) {
    case BodyShape::Sphere: return 4.0 * M_PI * r * r * s2;
    case BodyShape::Box: return 2.0 * (b.size.x() * b.size.y() + b.size.y() * b.size.z() + b.size.z() * b.size.x()) * s2;
    case BodyShape::Cylinder: return (2.0 * M_PI * r * r + 2.0 * M_PI * r * b.height) * s2;
    case BodyShape::Capsule: return (4.0 * M_PI * r * r + 2.0 * M_PI * r * b.height) * s2;
    case BodyShape::Mesh: {
      double a = 0.0;
      const auto& m = b.mesh_data;
      for (const auto& t : m.triangles)
        a += 0.5 * ((m.positions[t[1]] - m.positions[t[0]]).cast<double>().cross((m.positions[t[2]] - m.positions[t[0]]).cast<double>())).norm();
      return a * s2;
    }
  }
  return 0.0;
}

/// A count that is finite and >= 0, or infinity (NaN and negative sizes estimate as unbounded).
double sane(double v) { return std::isfinite(v) && v >= 0.0 ? v : (std::isnan(v) ? INFINITY : std::max(v, 0.0)); }

}  // namespace

std::string humanBytes(double bytes) {
  char buf[48];
  if (!std::isfinite(bytes)) return "unbounded";
  if (bytes >= 1e12) std::snprintf(buf, sizeof buf, "%.3g TB", bytes / 1e12);
  else if (bytes >= 1e9) std::snprintf(buf, sizeof buf, "%.3g GB", bytes / 1e9);
  else if (bytes >= 1e6) std::snprintf(buf, sizeof buf, "%.3g MB", bytes / 1e6);
  else std::snprintf(buf, sizeof buf, "%.3g kB", bytes / 1e3);
  return buf;
}

double machineMemoryBytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : 0.0;
}

namespace {
std::string formatCount(double n) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", n);
  return buf;
}
}  // namespace

std::string ResourceEstimate::str() const {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "about %s (%.3g fluid particles, %.3g boundary particles, %.3g body surface particles, %.3g grid cells%s)",
                humanBytes(bytes).c_str(), fluid_particles, boundary_particles, body_particles, grid_cells,
                cloth_nodes > 0 ? (", " + formatCount(cloth_nodes) + " cloth nodes").c_str() : "");
  return buf;
}

ResourceEstimate estimateResources(const SceneSpec& spec, SourceLoc* worst) {
  ResourceEstimate e;
  const SimulationSpec& sim = spec.simulation;
  const DomainSpec& dom = spec.domain;
  const FluidSpec& fl = spec.fluid;
  const double dx = fl.particle_spacing;
  double worst_bytes = -1.0;
  auto blame = [&](const SourceLoc& loc, double bytes) {
    if (worst && bytes > worst_bytes) *worst = loc, worst_bytes = bytes;
  };
  blame(fl.loc, 0.0);

  // Fluid: lattice points of the blocks, and what the nozzles emit over their active time.
  double blocks = 0.0, layer_points = 0.0, emitted = 0.0;
  for (const BlockSpec& b : fl.blocks) {
    double n = 1.0;
    for (int a = 0; a < 3; ++a) n *= std::max(1.0, std::floor(sane((b.max[a] - b.min[a]) / dx) + 1e-4));
    blocks += n;
    blame(b.loc, n * kBytesPerFluidParticle);
  }
  for (const InflowSpec& in : fl.inflows) {
    const double hu = in.shape == NozzleShape::Circle ? in.radius : 0.5 * in.width;
    const double hv = in.shape == NozzleShape::Circle ? in.radius : 0.5 * in.height;
    const double layer = (2.0 * std::floor(sane(hu / dx)) + 1.0) * (2.0 * std::floor(sane(hv / dx)) + 1.0);
    const double active = std::max(0.0, std::min(in.stop, sim.duration) - in.start);
    const double n = layer * std::ceil(sane(active * in.speed / dx) + 1.0);
    layer_points += layer;
    emitted += n;
    blame(in.loc, (fl.max_particles > 0 ? layer : n) * kBytesPerFluidParticle);
  }
  e.fluid_particles = fl.max_particles > 0 ? static_cast<double>(fl.max_particles) : blocks + emitted;
  if (fl.max_particles > 0) blame(fl.loc, e.fluid_particles * kBytesPerFluidParticle);

  // Boundary: the lattice shell of `layers` behind the walls (all six, an upper bound).
  const Eigen::Vector3d extent = dom.max - dom.min;
  const double L = dom.boundary_layers;
  double outer = 1.0, inner = 1.0, cells = 1.0;
  const double cell = (1.0 + skinRatio(fl)) * sim.support_ratio * dx;  // support + skin
  for (int a = 0; a < 3; ++a) {
    const double n = std::ceil(sane(extent[a] / dx));
    outer *= n + 2.0 * L;
    inner *= n;
    cells *= std::max(1.0, std::ceil(sane((extent[a] + 2.0 * (L + 1.0) * dx) / cell)));
  }
  e.boundary_particles = outer - inner;
  e.grid_cells = cells;
  blame(dom.loc, e.boundary_particles * kBytesPerBoundaryParticle + cells * kBytesPerGridCell);

  // Bodies: surface particles at dx, and a surface mesh with edges of dx / 2.
  for (const RigidBodySpec& b : spec.rigid_bodies) {
    const double area = sane(bodyArea(b) / (dx * dx));
    e.body_particles += area;
    blame(b.loc, area * kBytesPerBodyArea);
  }
  // Cloths: their nodes (springs, colours and coupling scale with them).
  for (const ClothSpec& c : spec.cloth) {
    const double n = c.nodeCount();
    e.cloth_nodes += n;
    blame(c.loc, n * kBytesPerClothNode);
  }
  // Soft bodies: their lattice nodes (a bound for a mesh), each with about twice a cloth node's springs.
  for (const SoftBodySpec& b : spec.soft_bodies) {
    const double n = cloth::softNodeBound(b, dx);
    e.cloth_nodes += 2.0 * n;
    blame(b.loc, 2.0 * n * kBytesPerClothNode);
  }
  e.bytes = (e.fluid_particles + layer_points) * kBytesPerFluidParticle +
            e.boundary_particles * kBytesPerBoundaryParticle + e.body_particles * kBytesPerBodyArea +
            e.grid_cells * kBytesPerGridCell + e.cloth_nodes * kBytesPerClothNode;
  // DFSPH's buffers beyond WCSPH's: the extrapolated walls' per-step lists (every boundary
  // particle), the two-level solve's pair sums and coarse operators (every fluid particle). The
  // blame stays with the sizes (domain, blocks, nozzles) that set these counts.
  if (fl.solver == FluidSolver::Dfsph) {
    if (fl.dfsph.walls == DfsphWalls::Extrapolated) {
      const double walls = e.boundary_particles + e.body_particles + e.cloth_nodes;
      e.bytes += walls * kBytesPerDfsphWallParticle;
    }
    if (fl.dfsph.coarse_interval > 0) {
      e.bytes += (e.fluid_particles + layer_points) * kBytesPerDfsphCoarseParticle +
                 e.grid_cells * kBytesPerDfsphCoarseGridCell;
    }
  }
  if (std::isnan(e.bytes)) e.bytes = INFINITY;

  // Steps per frame at the start: the CFL limit with the automatic (or given) speed of sound,
  // and the viscous limit of the laminar model (as Simulation::advanceFrame() computes them).
  if (e.fluid_particles > 0) {
    const double g = sim.gravity.norm();
    double vmax = 0.0;
    for (const BlockSpec& b : fl.blocks)
      vmax = std::max({vmax, std::sqrt(2.0 * g * std::max(0.0, b.max.z() - dom.min.z())), b.velocity.norm()});
    for (const InflowSpec& in : fl.inflows)
      vmax = std::max(vmax, std::sqrt(in.speed * in.speed + 2.0 * g * std::max(0.0, in.position.z() - dom.min.z())));
    const double c0 = fl.speed_of_sound > 0.0 ? fl.speed_of_sound : std::max(10.0 * vmax, 1.0);
    const double h = 0.5 * sim.support_ratio * dx;
    double limit = sim.cfl * h / c0;
    double nu = 0.0;
    for (const PhaseSpec& p : fl.phases) nu = std::max(nu, p.viscosity);
    // (the implicit viscosity has no viscous bound: set, or resolved from auto when spec is a compiled model's)
    const bool implicit = fl.solver == FluidSolver::Dfsph && fl.dfsph.viscosity_solve == ViscositySolve::Implicit;
    if (fl.viscosity_model == ViscosityModel::Laminar && nu > 0.0 && !implicit) limit = std::min(limit, 0.125 * h * h / nu);
    const double steps = (1.0 / sim.frame_rate) / limit;
    e.steps_per_frame = std::isfinite(steps) ? std::max(steps, static_cast<double>(sim.substeps)) : INFINITY;
  } else {
    e.steps_per_frame = sim.substeps;
  }
  return e;
}

namespace {
// DFSPH's viscous step bound for Monaghan's artificial viscosity (Monaghan 1992; pair terms in
// kernels/shared/pair_loops.h). Linearized about a resting lattice of spacing dx (every pair
// counted as approaching), the term is a damping of the relative velocities,
//     dv_i/dt = -alpha c0 h sum_j V_j |F(r_ij)| (x_ij . e)^2 / (r_ij^2 + 0.01 h^2) (v_i - v_j) . e,
// (grad W = F x, V_j = dx^3), whose fastest mode is the one of alternating layers (v_i ~ cos(pi
// x_i . e / dx)) at the rate lambda = alpha c0 S / dx with
//     S = sum_j h V_j |F(r_j)| (x_j . e)^2 / (r_j^2 + 0.01 h^2) (1 - cos(pi x_j . e / dx))  (unit: 1/dx).
// The explicit step v <- (1 - lambda dt) v reverses that mode when lambda dt > 1: a layer pair's
// approach becomes a separation within one step, the term switches off (approaching pairs only),
// and the layers bounce with period 2 (measured on the hydrostatic tank with the two-level solve,
// docs/dfsph.md "What makes the tank alternate": calm at alpha c0 dt / h = 0.49-0.69, 1-12 Pa at 0.79,
// the period-2 bounce at 0.99). So dt <= 1 / lambda = C h / (alpha c0) with C = dx / (h S): 0.685
// for the cubic spline at H = 2 dx (e along a lattice axis gives the largest S, 1.46 / dx).
double artificialViscosityStepFactor(int kernel, double support_ratio) {
  const double dx = 1.0, H = support_ratio * dx, h = 0.5 * H;
  const int reach = static_cast<int>(std::ceil(support_ratio));
  double S = 0.0;
  for (int x = -reach; x <= reach; ++x)
    for (int y = -reach; y <= reach; ++y)
      for (int z = -reach; z <= reach; ++z) {
        const double r2 = double(x * x + y * y + z * z), r = std::sqrt(r2);
        if (r2 == 0.0 || r >= H) continue;
        const double F = std::fabs(double(sph_grad_factor(kernel, static_cast<float>(r), static_cast<float>(H))));
        S += h * dx * dx * dx * F * double(x * x) / (r2 + 0.01 * h * h) * (1.0 - std::cos(3.14159265358979323846 * x / dx));
      }
  return S > 0.0 ? dx / (h * S) : 0.0;
}
}  // namespace

// fluid.dfsph.viscosity_solve: auto (the default) resolved to explicit or implicit in the compiled spec.
// Implicit where the explicit solve's viscous bound, 0.125 h^2 / nu (Morris et al. 1997), is shorter than
// fluid.dfsph.max_time_step, so the viscosity would set the step, and the scene meets what the loader asks of
// an implicit solve set by hand (io/scene_loader.cpp): free bodies with the strong body coupling, and cloth,
// and soft bodies lighter than the liquid, in XPBD substeps of at most kImplicitViscosityXpbdStep (their
// automatic max_time_step chooses it). Where the bound is longer the explicit solve costs nothing extra
// (water: 12.5 s at h = 1 cm). Measured (docs/dfsph.md, sessions 36-38): a ball falling through 0.05 m^2/s
// syrup at 5 ms, Stokes ratio 2.076 against the explicit 2.066, 9.4x faster; light hammocks in 0.1 m^2/s
// within 1 % at the anchors, 6-7x faster.
namespace {
void resolveViscositySolve(SceneSpec& s, double h, std::vector<std::string>& notes) {
  FluidSpec& fl = s.fluid;
  if (fl.dfsph.viscosity_solve != ViscositySolve::Auto) return;
  fl.dfsph.viscosity_solve = ViscositySolve::Explicit;
  if (fl.solver != FluidSolver::Dfsph || fl.viscosity_model != ViscosityModel::Laminar) return;
  double nu = 0.0;
  for (const PhaseSpec& p : fl.phases) nu = std::max(nu, p.viscosity);
  if (!(nu > 0.0)) return;
  const double bound = 0.125 * h * h / nu;
  if (!(bound < fl.dfsph.max_time_step)) return;
  std::string why_not;  // what the solve needs of the bodies (core/implicit_viscosity.h)
  if (implicitViscosityStaggeredBodies(s)) why_not = "free bodies with body_coupling: staggered";
  else if (const ImplicitViscosityLightBody light = implicitViscosityLightBody(s))
    why_not = light.cloth ? "cloth '" + light.name + "' is not in xpbd substeps of at most 0.5 ms"
                          : "soft body '" + light.name + "' is lighter than the liquid and not in xpbd substeps of at most 0.5 ms";
  if (!why_not.empty()) {
    notes.push_back("viscosity solved explicitly (fluid.dfsph.viscosity_solve: auto): its step bound " + fmt(bound * 1e3) +
                    " ms would set the step, but the implicit solve cannot take this scene: " + why_not);
    return;
  }
  fl.dfsph.viscosity_solve = ViscositySolve::Implicit;
  notes.push_back("viscosity solved implicitly (fluid.dfsph.viscosity_solve: auto): the explicit step bound 0.125 h^2 / nu = " +
                  fmt(bound * 1e3) + " ms is below max_time_step " + fmt(fl.dfsph.max_time_step * 1e3) +
                  " ms; 'viscosity_solve: explicit' keeps the bound");
}
}  // namespace

Compiled compile(const SceneSpec& spec, const ResourceLimits& limits) {
  Compiled out;
  Model& m = out.model;
  m.spec = spec;
  snapWallsToLattice(m.spec, spec.fluid.particle_spacing, m.warnings);
  const SimulationSpec& sim = spec.simulation;
  const DomainSpec& dom = m.spec.domain;  // the walls on the lattice (above)
  const FluidSpec& fl = m.spec.fluid;
  std::vector<InputIssue> issues;
  auto fail = [&](const SourceLoc& loc, const std::string& msg) {
    issues.push_back(InputIssue{loc.file, loc.line, loc.col, msg});
  };

  // --- Lengths and times -------------------------------------------------------------------
  m.max_steps_per_frame = limits.max_steps_per_frame;
  m.dx = fl.particle_spacing;
  m.support = sim.support_ratio * m.dx;
  m.h = 0.5 * m.support;
  resolveViscositySolve(m.spec, m.h, m.notes);  // before anything reads fl.dfsph.viscosity_solve
  // Neighbour lists reach a share of the support further, so they stay valid for several steps.
  m.skin = skinRatio(fl) * m.support;
  const double cell_size = m.support + m.skin;
  m.frame_dt = 1.0 / sim.frame_rate;
  const double exact_frames = sim.duration * sim.frame_rate;  // checked below: in [0.5, 1e9)
  m.num_frames = std::isfinite(exact_frames) ? std::max(1, static_cast<int>(std::lround(std::min(exact_frames, 1e9)))) : 1;
  const Eigen::Vector3d extent = dom.max - dom.min;
  if (extent.minCoeff() < 2.0 * m.dx)
    fail(dom.loc, "domain is thinner than two particle spacings (" + fmt(extent.minCoeff()) + " m < 2 x " +
                      fmt(m.dx) + " m)");
  if (fl.phases.empty()) fail(fl.loc, "no fluid phase defined");
  if (fl.phases.size() > SPH_MAX_PHASES)
    fail(fl.loc, "at most " + std::to_string(SPH_MAX_PHASES) + " phases are supported, got " +
                     std::to_string(fl.phases.size()));
  // Cloths beyond the supported node count are named as such, before the memory estimate.
  cloth::checkNodeBudget(spec.cloth, issues);
  if (!issues.empty()) throw InputError(issues);

  // --- Resources: refuse a scene that would not fit, before allocating anything ---------------
  {
    SourceLoc where;
    const ResourceEstimate est = estimateResources(m.spec, &where);  // viscosity_solve resolved (above)
    const double machine = machineMemoryBytes();
    const double budget = limits.max_bytes > 0 ? limits.max_bytes : machine;
    if (budget > 0 && !(est.bytes <= budget))
      throw InputError(where.file, where.line, where.col,
                       "the scene needs " + est.str() + ", more than " +
                           (limits.max_bytes > 0 ? "--max-memory " + humanBytes(budget)
                                                 : "this machine's memory (" + humanBytes(budget) + ")") +
                           ": use a larger fluid.particle_spacing or smaller sizes");
    if (sim.time_step_control == TimeStepControl::Subdivide && !(est.steps_per_frame <= limits.max_steps_per_frame))
      throw InputError(fl.loc.file.empty() ? sim.loc.file : fl.loc.file, fl.loc.file.empty() ? sim.loc.line : fl.loc.line,
                       fl.loc.file.empty() ? sim.loc.col : fl.loc.col,
                       "a frame would take about " + fmt(est.steps_per_frame) + " time steps (limit " +
                           fmt(limits.max_steps_per_frame) +
                           "): the CFL limit cfl h / (c0 + |v|) is tiny for the speeds this scene sets "
                           "(inflow speed, block velocity, speed_of_sound) or the viscosity; lower them (a viscous liquid: "
                           "DFSPH's implicit viscosity, fluid.dfsph.viscosity_solve, has no viscous bound)");
  }
  if (!(sim.duration * sim.frame_rate >= 0.5))
    fail(sim.loc, "simulation.duration " + fmt(sim.duration) + " s is shorter than half a frame (1 / frame_rate = " +
                      fmt(1.0 / sim.frame_rate) + " s): a run simulates whole frames");
  if (!(sim.duration * sim.frame_rate < 1e9))
    fail(sim.loc, "simulation.duration x frame_rate is " + fmt(sim.duration * sim.frame_rate) + " frames (limit 1e9)");
  if (!issues.empty()) throw InputError(issues);

  auto phaseIndex = [&](const std::string& name) -> int {
    if (name.empty()) return 0;
    for (std::size_t i = 0; i < fl.phases.size(); ++i)
      if (fl.phases[i].name == name) return static_cast<int>(i);
    return -1;
  };

  // --- Fluid blocks: cubic lattice at dx, first particle dx/2 inside each face ----------------
  for (const BlockSpec& b : fl.blocks) {
    const int ph = phaseIndex(b.phase);
    if (ph < 0) {
      fail(b.loc, "block refers to undefined phase '" + b.phase + "'");
      continue;
    }
    const PhaseSpec& P = fl.phases[static_cast<std::size_t>(ph)];
    // Whole lattice cells only: rounding up would put the last layer closer than dx/2 to a wall
    // at the block's face (and the boundary would blast it away).
    const Eigen::Vector3i count = ((b.max - b.min) / m.dx).array().unaryExpr([](double v) { return std::floor(v + 1e-4); })
                                      .cast<int>()
                                      .max(1);
    // The lattice starts dx/2 inside the min face, so a size that is not a multiple of dx leaves
    // its leftover at the max face; a block that ends on a closed wall but starts inside the tank
    // (a layer beside a dry region) is laid from the wall instead, so that the leftover lies at its
    // free or inner face and not against the wall (the walls are on the lattice, above).
    Eigen::Vector3d origin = b.min;
    for (int a = 0; a < 3; ++a) {
      const bool on_max_wall = dom.closed[static_cast<std::size_t>(2 * a + 1)] && std::abs(b.max[a] - dom.max[a]) <= 1e-3 * m.dx;
      const bool on_min_wall = dom.closed[static_cast<std::size_t>(2 * a)] && std::abs(b.min[a] - dom.min[a]) <= 1e-3 * m.dx;
      if (on_max_wall && !on_min_wall && b.max[a] - b.min[a] - count[a] * m.dx > 1e-3 * m.dx)
        origin[a] = b.max[a] - count[a] * m.dx;
    }
    const std::size_t before = out.initial.size();
    for (int k = 0; k < count.z(); ++k)
      for (int j = 0; j < count.y(); ++j)
        for (int i = 0; i < count.x(); ++i) {
          const Eigen::Vector3d x = origin + m.dx * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5);
          if ((x.array() >= b.max.array()).any()) continue;
          out.initial.push(x.cast<float>(), b.velocity.cast<float>(), P.colour.cast<float>(),
                           static_cast<uint32_t>(ph), static_cast<uint32_t>(out.initial.size()));
        }
    if (out.initial.size() == before)
      fail(b.loc, "block is smaller than the particle spacing (" + fmt(m.dx) + " m): it holds no particle");
  }

  // --- Nozzles: one layer of lattice points across the opening, perpendicular to the direction --
  for (const InflowSpec& in : fl.inflows) {
    Emitter e;
    e.spec = in;
    const int ph = phaseIndex(in.phase);
    if (ph < 0) {
      fail(in.loc, "inflow refers to undefined phase '" + in.phase + "'");
      continue;
    }
    e.phase = static_cast<uint32_t>(ph);
    e.direction = in.direction.normalized();
    // Orthonormal basis (u, v) of the nozzle plane.
    const Eigen::Vector3d helper = std::abs(e.direction.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
    const Eigen::Vector3d u = e.direction.cross(helper).normalized();
    const Eigen::Vector3d v = e.direction.cross(u);
    const double half_u = in.shape == NozzleShape::Circle ? in.radius : 0.5 * in.width;
    const double half_v = in.shape == NozzleShape::Circle ? in.radius : 0.5 * in.height;
    // In double first: a nozzle far wider than dx would overflow an int (the resource check above
    // has refused any that would not fit in memory).
    const int nu = static_cast<int>(std::min(std::floor(half_u / m.dx), 1.0e9));
    const int nv = static_cast<int>(std::min(std::floor(half_v / m.dx), 1.0e9));
    for (int j = -nv; j <= nv; ++j)
      for (int i = -nu; i <= nu; ++i) {
        const double a = i * m.dx, b = j * m.dx;
        if (in.shape == NozzleShape::Circle && a * a + b * b > in.radius * in.radius + 1e-12) continue;
        e.layer.push_back(in.position + a * u + b * v);
      }
    if (e.layer.empty()) fail(in.loc, "nozzle is smaller than the particle spacing: it would emit nothing");
    m.emitters.push_back(std::move(e));
  }
  if (!issues.empty()) throw InputError(issues);

  // --- Rigid bodies: shape -> mesh -> mass properties; surface particles at the fluid spacing ---
  const int kernel_id = sim.kernel == KernelType::WendlandC2 ? SPH_KERNEL_WENDLAND_C2 : SPH_KERNEL_CUBIC_SPLINE;
  double body_volume_scale = 0.0;  // bodyVolumeScale(), computed for the first body
  for (const RigidBodySpec& bs : spec.rigid_bodies) {
    rigid::RigidBody body;
    body.spec = bs;
    body.spec.mesh_data = TriMesh{};
    body.kind = bs.dynamic ? rigid::BodyKind::Dynamic
                           : (bs.motion.type != MotionType::None ? rigid::BodyKind::Kinematic : rigid::BodyKind::Static);
    if (bs.motion.type == MotionType::Keyframes && !bs.dynamic) {  // the loader checks these at their keys
      const auto& keys = bs.motion.keyframes;
      bool increasing = true;
      for (std::size_t k = 1; k < keys.size(); ++k) increasing = increasing && keys[k].time > keys[k - 1].time;
      if (keys.size() < 2 || !increasing) {
        fail(bs.loc, "rigid body '" + bs.name + "': a keyframed motion needs at least 2 keyframes with strictly increasing times");
        continue;
      }
    }
    if (bs.shape == BodyShape::Mesh && bs.mesh_data.triangles.empty()) {
      fail(bs.loc, "rigid body '" + bs.name + "': shape mesh but no mesh was loaded");
      continue;
    }
    TriMesh mesh = rigid::shapeMesh(bs, m.dx);
    // Bounded work: rigid::sampleSurface offers each triangle a barycentric grid of candidates at
    // dx / 5 along its longest edge, so a long, thin triangle (a 100 m cylinder's side) costs
    // (longest / (dx / 5))^2 / 2 candidates, however small its area.
    {
      double candidates = 0.0;
      for (const auto& t : mesh.triangles) {
        const Eigen::Vector3d a = mesh.positions[t[0]].cast<double>(), b = mesh.positions[t[1]].cast<double>(),
                              c = mesh.positions[t[2]].cast<double>();
        const double n = std::ceil(std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()}) / (0.2 * m.dx)) + 1.0;
        candidates += 0.5 * n * (n + 1.0);
      }
      if (!(candidates <= kMaxSurfaceCandidates)) {
        fail(bs.loc, "rigid body '" + bs.name + "': sampling its surface at the particle spacing would test about " +
                         fmt(candidates) + " points (limit " + fmt(kMaxSurfaceCandidates) +
                         "): the body is too large for the particle spacing");
        continue;
      }
    }
    const rigid::MassProperties mp = rigid::massProperties(mesh);
    if (!(mp.volume > 0.0)) {
      fail(bs.loc, "rigid body '" + bs.name + "' encloses no volume (" + fmt(mp.volume) + " m^3)");
      continue;
    }
    // Mass from the density, or the density from the mass (uniform either way).
    const double density = bs.mass > 0.0 ? bs.mass / mp.volume : bs.density;
    body.volume = mp.volume;
    body.mass = density * mp.volume;
    body.inertia = density * mp.inertia;
    body.inv_inertia = body.inertia.inverse();
    // Body frame: origin at the centre of mass.
    body.origin_offset = -mp.centre;
    for (auto& p : mesh.positions) p -= mp.centre.cast<float>();
    body.mesh = std::move(mesh);
    // Particles half a spacing inside the surface, as the walls' first layer lies dx/2 behind the
    // wall plane: fluid rests about dx from boundary particles, so its edge (dx/2 beyond its
    // particles) then meets the body's true surface, and the displaced volume is the body's.
    std::vector<Eigen::Vector3f> normals;
    body.particles = rigid::sampleSurface(body.mesh, m.dx, &normals);
    for (std::size_t i = 0; i < body.particles.size(); ++i) body.particles[i] -= 0.5f * static_cast<float>(m.dx) * normals[i];
    body.normals = std::move(normals);
    // Akinci et al. 2012 eq. 4 over the body's own particles: a single sampled layer gets the
    // volume of the missing ones; scaled so that a flat face weighs what a domain wall weighs
    // (bodyVolumeScale: 1 / 1.41 for the cubic spline at H = 2 dx).
    const std::vector<float> vol = akinciVolumes(body.particles, static_cast<float>(m.support), kernel_id);
    const double V0 = m.dx * m.dx * m.dx;
    if (body_volume_scale == 0.0) body_volume_scale = bodyVolumeScale(m.dx, m.support, kernel_id);
    body.volumes.resize(vol.size());
    for (std::size_t i = 0; i < vol.size(); ++i) body.volumes[i] = static_cast<float>(body_volume_scale * vol[i] / V0);
    m.bodies.push_back(std::move(body));
  }
  if (!issues.empty()) throw InputError(issues);
  for (RigidBodySpec& b : m.spec.rigid_bodies) b.mesh_data = TriMesh{};  // the Model keeps body.mesh

  // Bodies and closed walls in water: a film of one spacing dx between them. Buoyancy is the fluid's
  // pressure on a body's underside; with the body's surface on the wall no fluid particle fits
  // between the two boundary layers (each lies dx/2 behind its surface, and fluid rests dx from
  // boundary particles), so a buoyant body placed flush on the floor stayed stuck however light it was
  // (issue 15). In nature a film of water remains; the smallest film SPH resolves is one particle
  // layer, dx thick. A heavy body that reaches the wall has the same conflict the other way: the
  // water beneath it has nowhere to go within a step, and with the surfaces touching the last particle
  // under it was held from below by the wall's contact and squeezed through a hole of the body's one
  // sampled layer (session 31: scenes/floating_bodies.yaml's 4,000 kg/m^3 ball, landing at 1.3 m/s,
  // swallowed one that stayed 2-3 cm inside it; forced out instead, it was a spring that kicked the
  // ball off the floor at 110 N). So in a scene with fluid dynamic bodies touch the closed walls across
  // a film of dx (Model::wall_film; the contact and the position update see the walls moved in by it,
  // Simulation::integrateBodies), and a dynamic body whose surface lies closer than dx to a closed
  // wall is moved away from it to that gap at compile time (a note says so). Body pairs touch as they
  // are (their layers are dx apart at contact, where a particle does not fit anyway), and every body
  // of a scene without fluid touches the walls directly.
  if (!fl.blocks.empty() || !fl.inflows.empty()) {
    m.wall_film = m.dx;
    const double min_gap = m.wall_film;
    for (std::size_t k = 0; k < m.bodies.size(); ++k) {
      rigid::RigidBody& body = m.bodies[k];
      if (body.kind != rigid::BodyKind::Dynamic) continue;
      const rigid::BodyState s0 = rigid::initialState(body);
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = Eigen::Vector3d::Constant(-INFINITY);
      for (const auto& v : body.mesh.positions) {
        const Eigen::Vector3d w = s0.toWorld(v.cast<double>());
        lo = lo.cwiseMin(w);
        hi = hi.cwiseMax(w);
      }
      Eigen::Vector3d shift = Eigen::Vector3d::Zero();
      for (int a = 0; a < 3; ++a) {
        const double below = lo[a] - dom.min[a], above = dom.max[a] - hi[a];
        // (a body too wide for the box between two closed walls is left as placed)
        if (dom.closed[static_cast<std::size_t>(2 * a)] && below < min_gap && above - (min_gap - below) >= min_gap)
          shift[a] = min_gap - below;
        else if (dom.closed[static_cast<std::size_t>(2 * a + 1)] && above < min_gap && below - (min_gap - above) >= min_gap)
          shift[a] = -(min_gap - above);
      }
      if (shift.isZero()) continue;
      body.spec.position += shift;
      m.spec.rigid_bodies[k].position += shift;
      std::ostringstream note;
      note << "rigid body '" << body.spec.name << "' lay closer than one spacing dx = " << fmt(m.dx)
           << " m to a closed wall: moved by [" << fmt(shift.x()) << ", " << fmt(shift.y()) << ", " << fmt(shift.z())
           << "] m; in water, bodies touch the closed walls across a film of dx (one fluid layer; buoyancy acts through it)";
      m.notes.push_back(note.str());
    }
  }

  // Fluid placed where a body is: particles inside a body, or closer than dx to one of its
  // boundary particles (where the contact repulsion of pressure.cl would act at once), are removed.
  if (!m.bodies.empty() && out.initial.size() > 0) {
    const float cell = static_cast<float>(m.dx);
    HostGrid near{cell, {}};
    std::vector<Eigen::Vector3f> world;
    struct Placed { Eigen::Vector3d x; Eigen::Quaterniond q; double reach; };
    std::vector<Placed> placed;
    // Inside tests through each body's surface grid (a winding number per particle would pass over
    // every triangle: minutes for a large, finely tessellated body).
    std::vector<std::unique_ptr<ClosedSurface>> surfaces;
    for (const auto& body : m.bodies) surfaces.push_back(std::make_unique<ClosedSurface>(body.mesh));
    struct Known { bool valid = false, inside = false; Eigen::Vector3d point = Eigen::Vector3d::Zero(); double distance = 0; };
    std::vector<Known> known(m.bodies.size());
    for (const rigid::RigidBody& body : m.bodies) {
      const rigid::BodyState s0 = rigid::initialState(body);
      double reach = 0.0;
      for (const auto& v : body.mesh.positions) reach = std::max(reach, static_cast<double>(v.norm()));
      placed.push_back({s0.x, s0.q, reach});
      for (const auto& p : body.particles) {
        const Eigen::Vector3f w = s0.toWorld(p.cast<double>()).cast<float>();
        const Eigen::Vector3i c = near.coord(w);
        near.cells[HostGrid::key(c.x(), c.y(), c.z())].push_back(static_cast<uint32_t>(world.size()));
        world.push_back(w);
      }
    }
    HostParticles kept;
    std::size_t removed = 0;
    for (std::size_t i = 0; i < out.initial.size(); ++i) {
      const Eigen::Vector3f x = out.initial.pos[i].head<3>();
      bool clash = false;
      const Eigen::Vector3i c = near.coord(x);
      for (int dz = -1; dz <= 1 && !clash; ++dz)
        for (int dy = -1; dy <= 1 && !clash; ++dy)
          for (int dxc = -1; dxc <= 1 && !clash; ++dxc) {
            auto it = near.cells.find(HostGrid::key(c.x() + dxc, c.y() + dy, c.z() + dz));
            if (it == near.cells.end()) continue;
            for (uint32_t j : it->second)
              if ((world[j] - x).squaredNorm() < cell * cell) { clash = true; break; }
          }
      for (std::size_t b = 0; b < m.bodies.size() && !clash; ++b) {
        const Eigen::Vector3d local = placed[b].q.inverse() * (x.cast<double>() - placed[b].x);
        if (local.norm() > placed[b].reach) continue;
        // The last query's answer holds within its distance to the surface (consecutive lattice
        // points are close): deep inside a large body most points need no query of their own.
        Known& k = known[b];
        if (k.valid && (local - k.point).norm() < k.distance) {
          clash = k.inside;
        } else {
          k.inside = clash = surfaces[b]->inside(local, k.distance);
          k.point = local;
          k.valid = true;
        }
      }
      if (clash) {
        ++removed;
        continue;
      }
      kept.push(x, out.initial.vel[i].head<3>(), out.initial.colour[i].head<3>(), out.initial.phase[i],
                static_cast<uint32_t>(kept.size()));
    }
    if (removed > 0) {
      m.notes.push_back(std::to_string(removed) + " fluid particles inside or within dx of rigid bodies removed");
      out.initial = std::move(kept);
    }
  }
  {
    std::size_t moving = 0;
    for (const auto& b : m.bodies) moving += b.kind != rigid::BodyKind::Static;
    if (moving > 0 && (!fl.blocks.empty() || !fl.inflows.empty()))
      m.notes.push_back(std::to_string(moving) +
                        " moving rigid bod(ies): coupled to the fluid by pressure, viscosity and contact "
                        "(Akinci et al. 2012); contact with the closed walls (across a film of one spacing dx) and "
                        "between bodies");
  }

  // Fluid placed where a cloth is: particles closer than dx to a cloth node (where the contact
  // repulsion would act at once) are removed, as for bodies.
  if ((!spec.cloth.empty() || !spec.soft_bodies.empty()) && out.initial.size() > 0) {
    std::map<std::array<int64_t, 3>, std::vector<Eigen::Vector3d>> nodes;
    auto key = [&](const Eigen::Vector3d& x) {
      return std::array<int64_t, 3>{static_cast<int64_t>(std::floor(x.x() / m.dx)),
                                    static_cast<int64_t>(std::floor(x.y() / m.dx)),
                                    static_cast<int64_t>(std::floor(x.z() / m.dx))};
    };
    for (const ClothSpec& c : spec.cloth)
      for (const Eigen::Vector3d& x : cloth::nodePositions(c)) nodes[key(x)].push_back(x);
    for (const SoftBodySpec& b : spec.soft_bodies)
      for (const Eigen::Vector3d& x : cloth::softLattice(b, m.dx).x) nodes[key(x)].push_back(x);
    HostParticles kept;
    std::size_t removed = 0;
    for (std::size_t i = 0; i < out.initial.size(); ++i) {
      const Eigen::Vector3d x = out.initial.pos[i].head<3>().cast<double>();
      const auto k = key(x);
      bool clash = false;
      for (int64_t dz = -1; dz <= 1 && !clash; ++dz)
        for (int64_t dy = -1; dy <= 1 && !clash; ++dy)
          for (int64_t dxx = -1; dxx <= 1 && !clash; ++dxx) {
            const auto it = nodes.find({k[0] + dxx, k[1] + dy, k[2] + dz});
            if (it == nodes.end()) continue;
            for (const Eigen::Vector3d& y : it->second)
              if ((y - x).squaredNorm() < m.dx * m.dx) { clash = true; break; }
          }
      if (clash) {
        ++removed;
        continue;
      }
      kept.push(out.initial.pos[i].head<3>(), out.initial.vel[i].head<3>(), out.initial.colour[i].head<3>(),
                out.initial.phase[i], static_cast<uint32_t>(kept.size()));
    }
    if (removed > 0) {
      m.notes.push_back(std::to_string(removed) + " fluid particles within dx of cloth nodes removed" +
                        (spec.soft_bodies.empty() ? "" : " (soft-body nodes included)"));
      out.initial = std::move(kept);
    }
  }

  // --- Particle budget: initial + what the nozzles emit over their active time ---------------
  double emitted = 0.0;
  for (const Emitter& e : m.emitters) {
    const double active = std::max(0.0, std::min(e.spec.stop, sim.duration) - e.spec.start);
    emitted += static_cast<double>(e.layer.size()) * std::ceil(active * e.spec.speed / m.dx + 1.0);
  }
  if (fl.max_particles > 0) {
    m.capacity = static_cast<std::size_t>(fl.max_particles);
    if (m.capacity < out.initial.size())
      fail(fl.loc, "max_particles (" + std::to_string(fl.max_particles) + ") is below the " +
                       std::to_string(out.initial.size()) + " particles the blocks already hold");
  } else {
    m.capacity = out.initial.size() + static_cast<std::size_t>(emitted);
    if (!m.emitters.empty()) m.notes.push_back("particle budget: " + std::to_string(m.capacity) + " (automatic)");
  }
  if (m.capacity == 0 && m.bodies.empty() && spec.cloth.empty() && spec.soft_bodies.empty())
    fail(fl.loc, "the scene has no fluid, no rigid bodies, no cloth and no soft body: no blocks and no inflows");
  if (!issues.empty()) throw InputError(issues);

  // --- Speed of sound: 10x the largest expected speed keeps density errors near 1 % --------
  const double g = sim.gravity.norm();
  double vmax = 0.0;
  for (const BlockSpec& b : fl.blocks) {
    const double drop = std::max(0.0, b.max.z() - dom.min.z());
    vmax = std::max({vmax, std::sqrt(2.0 * g * drop), b.velocity.norm()});
  }
  for (const Emitter& e : m.emitters) {
    const double drop = std::max(0.0, e.spec.position.z() - dom.min.z());
    vmax = std::max(vmax, std::sqrt(e.spec.speed * e.spec.speed + 2.0 * g * drop));
  }
  if (fl.speed_of_sound > 0.0) {
    m.c0 = fl.speed_of_sound;
  } else {
    m.c0 = std::max(10.0 * vmax, 1.0);
    m.notes.push_back("speed of sound: " + fmt(m.c0) + " m/s (automatic: 10 x expected max speed " + fmt(vmax) +
                      " m/s)");
  }
  for (const PhaseSpec& p : fl.phases) m.max_viscosity = std::max(m.max_viscosity, p.viscosity);
  // DFSPH's viscous step bound of the artificial term (artificialViscosityStepFactor above).
  if (fl.viscosity_model == ViscosityModel::Artificial && fl.artificial_viscosity > 0.0)
    m.artificial_step_factor = artificialViscosityStepFactor(
        sim.kernel == KernelType::WendlandC2 ? SPH_KERNEL_WENDLAND_C2 : SPH_KERNEL_CUBIC_SPLINE, sim.support_ratio);

  // --- Neighbour grid: cell = list radius (support + skin), covering domain and boundary layers ---
  const int layers = dom.boundary_layers;
  const double margin = (layers + 1) * m.dx;
  const Eigen::Vector3d origin = dom.min - Eigen::Vector3d::Constant(margin);
  const Eigen::Vector3d span = extent + Eigen::Vector3d::Constant(2.0 * margin);
  Eigen::Vector3i dims;
  // Cells counted in double before any int conversion (a domain to 9e18 m overflows an int).
  double cells = 1.0;
  for (int a = 0; a < 3; ++a) cells *= std::max(1.0, std::ceil(span[a] / cell_size));
  if (!(cells <= 2.0e8))
    fail(dom.loc, "domain too large for the particle spacing: " + fmt(cells) + " grid cells (limit 2e8)");
  for (int a = 0; a < 3; ++a) dims[a] = std::max(1, static_cast<int>(std::min(std::ceil(span[a] / cell_size), 2.0e8)));
  if (!issues.empty()) throw InputError(issues);

  // --- Boundary particles behind each closed wall (Akinci et al. 2012) ------------------------
  // A lattice point outside the box is a boundary particle when every wall it lies beyond is closed.
  {
    std::vector<Eigen::Vector3f> pts;
    const auto xs = axisLattice(dom.min.x(), dom.max.x(), m.dx, layers);
    const auto ys = axisLattice(dom.min.y(), dom.max.y(), m.dx, layers);
    const auto zs = axisLattice(dom.min.z(), dom.max.z(), m.dx, layers);
    for (double z : zs)
      for (double y : ys)
        for (double x : xs) {
          const Eigen::Vector3d p(x, y, z);
          bool outside = false, allowed = true;
          for (int a = 0; a < 3; ++a) {
            if (p[a] < dom.min[a]) { outside = true; allowed = allowed && dom.closed[static_cast<std::size_t>(2 * a)]; }
            if (p[a] > dom.max[a]) { outside = true; allowed = allowed && dom.closed[static_cast<std::size_t>(2 * a + 1)]; }
          }
          if (outside && allowed) pts.push_back(p.cast<float>());
        }
    // Volumes: when the layers span the whole kernel support, fluid and wall together form a
    // complete lattice and every boundary particle's volume is exactly dx^3 (Akinci's
    // V_b = 1 / sum_k W_bk evaluated over that complete lattice). With fewer layers the wall is
    // incomplete and Akinci et al. 2012 eq. 4 over the boundary particles alone compensates for
    // the missing ones (a single layer gives ~6 % extra density next to the wall at rest).
    const int kernel = sim.kernel == KernelType::WendlandC2 ? SPH_KERNEL_WENDLAND_C2 : SPH_KERNEL_CUBIC_SPLINE;
    const double V0 = m.dx * m.dx * m.dx;
    const bool complete = layers >= static_cast<int>(std::ceil(sim.support_ratio - 1e-9));
    std::vector<float> vol = complete ? std::vector<float>(pts.size(), static_cast<float>(V0))
                                      : akinciVolumes(pts, static_cast<float>(m.support), kernel);
    std::vector<Eigen::Vector4f> normal(pts.size(), Eigen::Vector4f::Zero());  // none on the lattice
    if (!complete)
      m.notes.push_back("boundary: " + std::to_string(layers) + " layer(s) for a support of " +
                        fmt(sim.support_ratio) + " dx: Akinci volumes compensate the missing layers");
    // Static rigid bodies: their particles, placed in the world, join the walls' (volumes from
    // the body alone, computed at compile above).
    for (const rigid::RigidBody& body : m.bodies) {
      if (body.kind != rigid::BodyKind::Static) continue;
      const rigid::BodyState s0 = rigid::initialState(body);
      for (std::size_t i = 0; i < body.particles.size(); ++i) {
        pts.push_back(s0.toWorld(body.particles[i].cast<double>()).cast<float>());
        vol.push_back(static_cast<float>(body.volumes[i] * V0));
        const Eigen::Vector3f nw = (s0.q * body.normals[i].cast<double>()).cast<float>();
        normal.emplace_back(nw.x(), nw.y(), nw.z(), 1.0f);
      }
    }
    // Sort by cell (stable: ties keep lattice order) and build the cell start table.
    std::vector<std::pair<uint32_t, uint32_t>> keyed(pts.size());
    for (uint32_t i = 0; i < pts.size(); ++i) {
      Eigen::Vector3i c = ((pts[i].cast<double>() - origin) / cell_size).array().floor().cast<int>();
      c = c.cwiseMax(0).cwiseMin(dims - Eigen::Vector3i::Ones());
      keyed[i] = {static_cast<uint32_t>(c.x() + dims.x() * (c.y() + dims.y() * c.z())), i};
    }
    std::stable_sort(keyed.begin(), keyed.end(), [](auto& a, auto& b) { return a.first < b.first; });
    const std::size_t num_cells = static_cast<std::size_t>(cells);
    std::vector<uint32_t> count(num_cells + 1, 0);
    m.boundary.reserve(pts.size());
    m.boundary_normal.reserve(pts.size());
    for (auto& [cell, i] : keyed) {
      const Eigen::Vector3f& p = pts[i];
      m.boundary.emplace_back(p.x(), p.y(), p.z(), static_cast<float>(vol[i] / V0));
      m.boundary_normal.push_back(normal[i]);
      ++count[cell];
    }
    m.boundary_cell_start.assign(num_cells + 1, 0);
    for (std::size_t c = 0; c < num_cells; ++c) m.boundary_cell_start[c + 1] = m.boundary_cell_start[c] + count[c];
  }

  // --- Cloths: nodes, springs, colours (core/cloth.h) -----------------------------------
  m.cloth = cloth::compileCloths(spec.cloth, issues, spec.soft_bodies, m.dx);
  for (int a = 0; a < 3; ++a) {
    m.cloth.walls_min[a] = static_cast<float>(dom.min[a]);
    m.cloth.walls_max[a] = static_cast<float>(dom.max[a]);
  }
  for (int w = 0; w < 6; ++w)
    if (dom.closed[static_cast<std::size_t>(w)]) m.cloth.closed_mask |= 1u << w;
  m.cloth.wall_margin = static_cast<float>(1e-4 * m.dx);
  // XPBD substeps, automatic (max_time_step 0, the default): a ball is a kinematic obstacle inside the
  // XPBD solve and takes the nodes' momentum change, m shift / h per node and sweep, so holding a ball
  // of weight W in a (sub)step h takes a stretch of about W h^2 / (n m) over n sweeps on nodes of mass
  // m. The automatic substep keeps it under 5 % of the shortest rest length L0: h = sqrt(0.05 L0 n m
  // / W). Measured (docs/dfsph.md, session 18): balls_on_cloth.yaml's metal ball (W = 8.1 N) on its
  // sheet (0.3 g nodes, 16 sweeps, 8 mm) gives h = 0.49 ms; it rests within 1 mm of the converged
  // height at 0.5 ms, 3.7 mm deep at 1 ms, and goes through at 5 ms.
  // Under the implicit viscosity a cloth, or a soft body lighter than the liquid, takes substeps of at
  // most kImplicitViscosityXpbdStep (core/scene_spec.h: in one step light sheets swung or blew up in
  // syrup; docs/dfsph.md, sessions 38-39). Neither: one step.
  {
    double W = 0.0;
    for (const rigid::RigidBody& b : m.bodies)
      if (b.kind == rigid::BodyKind::Dynamic && b.spec.shape == BodyShape::Sphere)
        W = std::max(W, b.mass * spec.simulation.gravity.norm());
    const bool implicit_viscosity = fl.solver == FluidSolver::Dfsph && fl.dfsph.viscosity_solve == ViscositySolve::Implicit;
    const double rho_liquid = densestLiquid(fl);
    struct Setting {
      std::string name;
      double max_time_step;  // -1: not XPBD
      bool light;            // a cloth, or a soft body lighter than the liquid
    };
    std::vector<Setting> setting;  // cloths then soft bodies, as m.cloth's bodies
    for (const ClothSpec& c : spec.cloth) setting.push_back({c.name, c.solver == ClothSolver::Xpbd ? c.max_time_step : -1.0, true});
    for (const SoftBodySpec& b : spec.soft_bodies)
      setting.push_back({b.name, b.solver == ClothSolver::Xpbd ? b.max_time_step : -1.0, lighterThanLiquid(b, rho_liquid)});
    for (std::size_t c = 0; c < setting.size() && c < m.cloth.first_node.size(); ++c) {
      if (setting[c].max_time_step != 0.0) continue;  // set, or explicit
      double h = INFINITY;
      std::string why;
      if (W > 0.0) {
        double mass = INFINITY, L0 = INFINITY;
        for (uint32_t i = m.cloth.first_node[c]; i < m.cloth.first_node[c] + m.cloth.num_nodes[c]; ++i)
          if (m.cloth.x0[i].w() > 0.0f) mass = std::min(mass, double(m.cloth.mass[i]));
        for (uint32_t k = m.cloth.first_spring[c]; k < m.cloth.first_spring[c] + m.cloth.num_springs[c]; ++k)
          L0 = std::min(L0, double(m.cloth.prm[k].x()));
        if (std::isfinite(mass) && std::isfinite(L0)) {
          h = std::sqrt(0.05 * L0 * m.cloth.iterations[c] * mass / W);
          why = "from its lightest node, " + fmt(mass * 1e3) + " g, and the heaviest ball's weight, " + fmt(W) + " N";
        }
      }
      if (implicit_viscosity && setting[c].light && kImplicitViscosityXpbdStep < h) {
        h = kImplicitViscosityXpbdStep;
        why = "the implicit viscosity's limit for cloth and bodies lighter than the liquid";
      }
      if (!std::isfinite(h)) continue;
      m.cloth.xpbd_dt_limit = std::min(m.cloth.xpbd_dt_limit, h);
      m.notes.push_back("'" + setting[c].name + "': XPBD substeps of at most " + fmt(h * 1e3) + " ms (automatic: " + why +
                        "; max_time_step sets them)");
    }
  }
  for (const ClothSpec& c : spec.cloth)
    for (const std::string& key : c.unused_keys)
      m.warnings.push_back(key + " is not used: cloth '" + c.name + "' is a mesh (its vertices and edges set the nodes and springs)");
  if (!issues.empty()) throw InputError(issues);

  // --- Device constants ------------------------------------------------------------------
  SimParams& P = m.params;
  for (int a = 0; a < 3; ++a) {
    P.grid_origin[a] = static_cast<float>(origin[a]);
    P.grid_dims[a] = dims[a];
    P.domain_min[a] = static_cast<float>(dom.min[a]);
    P.domain_max[a] = static_cast<float>(dom.max[a]);
  }
  P.cell_size = static_cast<float>(cell_size);
  P.support = static_cast<float>(m.support);
  P.h = static_cast<float>(m.h);
  P.rest_volume = static_cast<float>(m.dx * m.dx * m.dx);
  P.closed_mask = 0;
  for (int w = 0; w < 6; ++w)
    if (dom.closed[static_cast<std::size_t>(w)]) P.closed_mask |= 1u << w;
  P.kernel_type = sim.kernel == KernelType::WendlandC2 ? SPH_KERNEL_WENDLAND_C2 : SPH_KERNEL_CUBIC_SPLINE;
  P.eos = fl.equation_of_state == EquationOfState::Tait ? SPH_EOS_TAIT : SPH_EOS_LINEAR;
  P.clamp_negative_pressure = fl.clamp_negative_pressure ? 1u : 0u;
  P.background_pressure = static_cast<float>(fl.background_pressure);
  P.n_boundary = static_cast<sph_uint>(m.boundary.size());
  P.num_cells = static_cast<sph_uint>(cells);
  P.c0 = static_cast<float>(m.c0);
  P.alpha = static_cast<float>(fl.artificial_viscosity);
  P.body_viscosity = fl.body_viscosity == BodyViscosity::Physical ? 1u : 0u;
  P.colour_diffusion = static_cast<float>(fl.colour_diffusion);
  for (std::size_t i = 0; i < fl.phases.size(); ++i) {
    P.phase_rest_density[i] = static_cast<float>(fl.phases[i].rest_density);
    P.phase_mass[i] = static_cast<float>(fl.phases[i].rest_density * m.dx * m.dx * m.dx);
    P.phase_viscosity[i] = static_cast<float>(fl.phases[i].viscosity);
  }

  // --- Stage mask: only what the scene calls for ------------------------------------------
  const bool laminar = fl.viscosity_model == ViscosityModel::Laminar;
  m.stages.set(Stage::Inflow, !m.emitters.empty());
  m.stages.set(Stage::Grid, true);
  m.stages.set(Stage::Density, true);
  // The pressure solver: WCSPH's pressure force, or DFSPH's two solves (core/dfsph.h).
  const bool dfsph = fl.solver == FluidSolver::Dfsph;
  m.stages.set(Stage::Pressure, !dfsph);
  m.stages.set(Stage::DivergenceSolve, dfsph && fl.dfsph.divergence_solve);
  m.stages.set(Stage::DensitySolve, dfsph);
  m.stages.set(Stage::Viscosity, laminar ? m.max_viscosity > 0.0 : fl.artificial_viscosity > 0.0);
  m.stages.set(Stage::ColourDiffusion, fl.colour_diffusion > 0.0);
  // No-slip ghost velocities (Adami et al. 2012 eq. 22-23) where the fluid-boundary viscous term
  // is the laminar (physical) one: every boundary particle with the laminar model, the bodies'
  // with body_viscosity physical (the artificial term stays with the wall's velocity: it is a
  // numerical viscosity). DFSPH (its viscous pass and the bodies' viscous reaction read the same
  // ghost velocities): `ghost` every boundary particle; `auto` only the moving bodies' particles
  // where their term is laminar (viscosity_model laminar or body_viscosity physical), the walls
  // keeping their own velocity as before session 10, so DFSPH scenes without moving bodies run as
  // before. Session 10 measured the towed and falling balls' Stokes drag: 0.75-0.82 and 1.66-1.79
  // x 6 pi mu R U without them, inside the wall factor's band with them (docs/forces.md).
  bool moving_bodies = false;
  for (const auto& b : m.bodies) moving_bodies = moving_bodies || b.kind != rigid::BodyKind::Static;
  const BoundaryVelocity bv = fl.boundary_velocity;
  const bool body_laminar = laminar || fl.body_viscosity == BodyViscosity::Physical;
  if (bv == BoundaryVelocity::Wall) m.ghost_velocity_mode = 0;
  else if (bv == BoundaryVelocity::Ghost) m.ghost_velocity_mode = 1;
  else if (dfsph) m.ghost_velocity_mode = body_laminar && moving_bodies ? 2u : 0u;
  else if (laminar) m.ghost_velocity_mode = 1;
  else m.ghost_velocity_mode = fl.body_viscosity == BodyViscosity::Physical ? 2u : 0u;
  // fluid.body_ambient_pressure: auto is subtract with WCSPH and keep with DFSPH (session 33: DFSPH's towed
  // ball in Stokes flow reads a drag that grows with the ambient pressure under either rule, 4 % under
  // its band with subtract at 1 kPa; WCSPH's is the same at 1 and 2 kPa with subtract; docs/forces.md).
  const BodyAmbientPressure rule = fl.body_ambient_pressure == BodyAmbientPressure::Auto
                                       ? (dfsph ? BodyAmbientPressure::Keep : BodyAmbientPressure::Subtract)
                                       : fl.body_ambient_pressure;
  m.body_ambient_subtract = (!dfsph || fl.dfsph.walls == DfsphWalls::Extrapolated) && moving_bodies &&
                            rule == BodyAmbientPressure::Subtract;
  m.stages.set(Stage::Integrate, true);
  m.stages.set(Stage::RigidDynamics, moving_bodies);
  m.stages.set(Stage::RigidCoupling, moving_bodies && m.capacity > 0);
  m.stages.set(Stage::Haptics, m.spec.haptics.enabled && moving_bodies);  // a `haptics` section and a body to hold
  m.stages.set(Stage::Cloth, m.cloth.nodes() > 0);
  m.stages.set(Stage::ClothCoupling, m.cloth.nodes() > 0 && m.capacity > 0);
  m.stages.set(Stage::Diagnostics, true);
  m.stages.set(Stage::Probes, spec.probes.any() && m.capacity > 0);

  // --- Probes: every sample point inside the domain -----------------------------------------
  auto inside = [&](const Eigen::Vector3d& x) {
    return (x.array() >= dom.min.array()).all() && (x.array() <= dom.max.array()).all();
  };
  for (const PointProbeSpec& p : spec.probes.points)
    if (!inside(p.position))
      fail(p.loc, "probe '" + p.name + "' at [" + fmt(p.position.x()) + ", " + fmt(p.position.y()) + ", " +
                      fmt(p.position.z()) + "] m is outside the domain");
  for (const GaugeSpec& g : spec.probes.gauges)
    if (!inside(g.position))
      fail(g.loc, "gauge '" + g.name + "' foot at [" + fmt(g.position.x()) + ", " + fmt(g.position.y()) + ", " +
                      fmt(g.position.z()) + "] m is outside the domain");
  if (!issues.empty()) throw InputError(issues);

  // Fixed build options: the kernel and viscosity model are compile-time constants on the device.
  m.program_options = "-cl-std=CL1.2 -DSPH_KERNEL=" + std::to_string(P.kernel_type) +
                      " -DSPH_LAMINAR=" + std::string(laminar ? "1" : "0");
  return out;
}

}  // namespace sph
