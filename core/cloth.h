// Cloth: anchored mass-spring nets whose nodes are particles (issue 11; the SPHaptics paper's cloth).
//
// Design. compile() turns each `cloth` item into nodes on a regular grid and springs between them
// (Provot 1995: stretch between grid neighbours, shear along cell diagonals, bend between nodes two
// apart). All nodes of all cloths live in one array; the springs of each node are one row of a
// compressed table (the paper's lookup table), built once:
//
//   node i:      row_start[i] .. row_start[i+1]-1  ->  entry e: spring[e] (id), other[e] (the other end)
//   spring s:    ends[s] = (a, b) with a < b; prm[s] = (rest length, k, dashpot c, tear strain); broken[s]
//
// Each spring appears twice, once in each end's row, so every kernel gathers: a node reads its
// row and writes only itself (no float atomics: runs are bitwise deterministic on a device).
//
// Two solvers (cloth[].solver):
//  - xpbd (default): XPBD distance constraints (Macklin, Mueller, Chentanez 2016, eq. 18 with the
//    damping of eq. 26), stable at any stiffness and step. Parallel scheme: graph-coloured
//    Gauss-Seidel. The springs are edge-coloured at compile time so that no two springs of a colour
//    share a node; each colour is one gather pass in which a node applies the correction of its
//    (at most one) spring of that colour. Both ends compute the same correction from the same
//    inputs (ordered a < b), so the pass is exact Gauss-Seidel without atomics. Chosen over Jacobi
//    because Jacobi needs an under-relaxation factor and converges far slower on long chains of
//    stiff constraints (a hanging chain), while colouring costs only one dispatch per colour.
//  - explicit: the paper's mass-spring forces, symplectic (semi-implicit) Euler. Its step limit,
//    2 / omega_max with omega_max bounded by Gershgorin's theorem over the springs (single mass on a
//    spring: 2 sqrt(m/k)), reduced for the dashpots (Belytschko, Liu, Moran 2000, eq. 6.3.38:
//    dt <= 2/omega (sqrt(1 + xi^2) - xi)), is enforced by subdividing the step, never ignored.
//    Its positions are kept as two floats, hi (the shared position buffer) + lo (ClothSim::xlo_),
//    so that float rounding of the positions does not feed energy into stiff springs.
//  - air drag (both solvers) is implicit on the whole velocity: at rest the springs and anchors
//    carry the full weight (kernels/cloth.cl, cloth_xpbd_predict).
#pragma once

#include "core/cl_context.h"
#include "core/scene_spec.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace sph {
struct InputIssue;
}

namespace sph::cloth {

enum SpringKind : uint32_t { kStretch = 0, kShear = 1, kBend = 2, kBodyDiagonal = 3 };  ///< soft bodies: edges, face and body diagonals of a cell: kStretch, kShear, kBodyDiagonal
constexpr double kMaxNodes = 1e6;  ///< nodes of all cloths of a scene, at most (about 400 MB of tables)
constexpr uint32_t kNoSlot = 0xffffffffu;

/// Rest positions of a cloth's nodes in the world frame; node (i, j) has index j * resolution_x + i.
std::vector<Eigen::Vector3d> nodePositions(const ClothSpec& c);

/// The nodes an anchor pins (indices into nodePositions); empty when it pins none.
std::vector<uint32_t> anchoredNodes(const ClothSpec& c, const ClothAnchorSpec& a, const std::vector<Eigen::Vector3d>& x);

/// A keyframed anchor's path (scene order of its keys): offset from the placed position.
struct AnchorTrack {
  std::vector<double> time;              ///< strictly increasing (unit: s)
  std::vector<Eigen::Vector3d> offset;   ///< (unit: m)
  /// Piecewise-linear offset at t, held before the first key and after the last (unit: m).
  Eigen::Vector3d offsetAt(double t) const;
  /// Its time derivative at t, right-continuous (the slope of the segment [t_k, t_k+1) holding t);
  /// zero before the first key and from the last on (unit: m/s).
  Eigen::Vector3d velocityAt(double t) const;
};

/// A soft body's lattice (see softLattice): cubic cells of `spacing` (per axis: the box's extents
/// rounded to whole cells), each cell's 8 corners nodes.
///
///   corner c of cell (i, j, k) is node (i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1))
///   its 28 springs are all pairs of its corners: 12 edges (corner bits differ in 1 place),
///   12 face diagonals (2 places), 4 body diagonals (3 places)
struct SoftLattice {
  Eigen::Vector3d spacing = Eigen::Vector3d::Zero();   ///< cell size along the body axes (unit: m)
  std::array<int, 3> cells_per_axis{{0, 0, 0}};        ///< the bounding grid's cells along each axis (unit: 1)
  std::vector<Eigen::Vector3d> x;                      ///< node positions, world frame (unit: m)
  std::vector<std::array<int, 3>> node_ijk;            ///< node lattice indices, 0 .. cells_per_axis
  std::vector<std::array<uint32_t, 8>> cells;          ///< the corner nodes (indices into x) of every filled cell
  std::vector<std::array<int, 3>> cell_ijk;            ///< lattice index of every filled cell
};

/// The lattice of a soft body: a box of `size` split into round(size / spacing) cells per axis
/// (at least 1), or the cells of a grid of `spacing` over the mesh's bounds whose centres lie inside
/// the closed mesh (ClosedSurface). `dx`: the fluid's spacing, the default lattice spacing (unit: m).
SoftLattice softLattice(const SoftBodySpec& s, double dx);

/// A soft body's node count before its lattice is built: the bounding grid's nodes, an upper
/// bound for a mesh (unit: 1); 0 when it has no spacing.
double softNodeBound(const SoftBodySpec& s, double dx);

/// Per-cell spring constants of a cubic cell of side a (unit: m) for Young's modulus E (unit: Pa):
/// (edge, face diagonal, body diagonal) (unit: N/m). See compileCloths for the derivation.
Eigen::Vector3d softSpringStiffness(double E, double a);

/// Every cloth of a scene, compiled.
struct ClothModel {
  // Per cloth (scene order).
  std::vector<uint32_t> first_node;   ///< index of the cloth's first node
  std::vector<uint32_t> num_nodes;    ///< its node count
  std::vector<uint32_t> first_spring; ///< index of its first spring (springs are grouped per cloth)
  std::vector<uint32_t> num_springs;
  // Per node (all cloths).
  std::vector<Eigen::Vector4f> x0;       ///< initial position (unit: m); w = inverse mass (unit: 1/kg), 0 = anchored
  std::vector<float> mass;               ///< node mass (also for anchored nodes) (unit: kg)
  std::vector<float> drag;               ///< air damping (unit: 1/s)
  std::vector<Eigen::Vector4f> anchor;   ///< anchored nodes: velocity (unit: m/s), w = stop time (unit: s);
                                         ///< keyframed: w = -(track + 1), xyz unused
  std::vector<AnchorTrack> tracks;       ///< keyframed anchors' paths
  std::vector<uint32_t> cloth_of;        ///< cloth index of each node
  // Compressed spring rows (each spring in both ends' rows).
  std::vector<uint32_t> row_start;       ///< (nodes + 1)
  std::vector<uint32_t> spring;          ///< entry -> spring id
  std::vector<uint32_t> other;           ///< entry -> the other end's node index
  // Per spring.
  std::vector<uint32_t> ends;            ///< (springs x 2): a < b
  std::vector<Eigen::Vector4f> prm;      ///< rest length (unit: m), k (unit: N/m), dashpot (unit: N s/m), tear strain (unit: 1)
  std::vector<uint32_t> kind;            ///< SpringKind
  // XPBD: edge colouring (no two springs of a colour share a node) and, per colour, each node's
  // entry of that colour: slot[c * nodes + i] = entry index or kNoSlot.
  uint32_t num_colours = 0;
  std::vector<uint32_t> slot;
  std::vector<uint8_t> xpbd;             ///< per cloth: 1 = xpbd, 0 = explicit
  std::vector<uint32_t> iterations;      ///< per cloth: XPBD Gauss-Seidel sweeps per step (unit: 1)
  bool any_tear = false;                 ///< some spring can break
  /// Explicit solver: the largest stable step over the explicit cloths (unit: s); inf when none.
  double explicit_dt_limit = 0.0;
  /// XPBD: the longest substep over the XPBD cloths and soft bodies (their max_time_step) (unit: s); inf when none.
  double xpbd_dt_limit = 0.0;
  /// The domain's closed walls, which hold the nodes as they hold the fluid (integrate.cl): a free
  /// node past one is put back just inside and loses its velocity into it.
  Eigen::Vector4f walls_min = Eigen::Vector4f::Zero();  ///< (unit: m)
  Eigen::Vector4f walls_max = Eigen::Vector4f::Zero();  ///< (unit: m)
  uint32_t closed_mask = 0;                             ///< bit 2a: the wall at min of axis a is closed; 2a + 1: at max
  float wall_margin = 0.0f;                             ///< how far inside a node is put back (unit: m)
  // Soft bodies: items num_cloths .. are the scene's soft_bodies (in order), nodes and springs like
  // a cloth's. Per soft body, its lattice cells (for the surface mesh): corner nodes (global
  // indices) and the 28 springs among them (global spring ids).
  std::size_t num_cloths = 0;
  struct SoftCells {
    std::array<int, 3> cells_per_axis{{0, 0, 0}};
    std::vector<std::array<int, 3>> ijk;
    std::vector<std::array<uint32_t, 8>> nodes;
    std::vector<std::array<uint32_t, 28>> springs;
  };
  std::vector<SoftCells> soft;
  std::size_t items() const { return first_node.size(); }
  bool isSoft(std::size_t item) const { return item >= num_cloths; }
  std::size_t nodes() const { return x0.size(); }
  std::size_t springs() const { return prm.size(); }
};

/// Reports (into `issues`, at the cloth) the first cloth whose nodes, with those of the cloths
/// before it, pass kMaxNodes; compile() calls it before its memory estimate so that a huge cloth
/// is named as such. Returns whether all fit.
bool checkNodeBudget(const std::vector<ClothSpec>& specs, std::vector<InputIssue>& issues);

/// Builds the nodes, springs and colours of every cloth, then of every soft body (items after the
/// cloths; `dx` is their default lattice spacing, unit: m); reports bad input (anchors that pin no
/// node, duplicate names) into `issues` with the item's location.
ClothModel compileCloths(const std::vector<ClothSpec>& specs, std::vector<InputIssue>& issues,
                         const std::vector<SoftBodySpec>& soft = {}, double dx = 0.0);

/// What a cloth looks like at one moment (host copy, double precision sums).
struct ClothReport {
  double kinetic = 0;         ///< (unit: J)
  double potential = 0;       ///< gravity, relative to z = 0 along -g (unit: J)
  double elastic = 0;         ///< springs, T^2 / 2k with T the tension: k (L - L0), XPBD lambda / dt^2 (unit: J)
  double max_strain = 0;      ///< largest (L - L0) / L0 over the unbroken springs (unit: 1)
  uint32_t broken = 0;        ///< broken springs
  Eigen::Vector3d anchor_force = Eigen::Vector3d::Zero();  ///< force of the springs on the anchored nodes, sum of T u (unit: N)
  double energy() const { return kinetic + potential + elastic; }
};

/// A sphere that the cloth's nodes collide with (a ball: a rigid body of shape sphere).
struct SphereCollider {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< (unit: m)
  double radius = 0;                                 ///< (unit: m)
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();///< of its centre (unit: m/s)
  double friction = 0.5;                             ///< Coulomb coefficient against the nodes (unit: 1)
};

/// Where a cutter (a rigid body with `cutter: true`) is: the pose of its body frame (the frame of
/// its mesh, origin at the centre of mass).
struct CutterPose {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();             ///< centre of mass, world (unit: m)
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();        ///< body -> world
};

/// The cloth state on the device and its time step. Owns its buffers.
class ClothSim {
 public:
  ClothSim(const ClothModel& model, ClContext& cl, KernelSet& kernels);
  /// Advances every cloth by dt (unit: s) from time t (unit: s) under gravity g (unit: m/s^2).
  /// Explicit cloths take ceil(dt / limit) substeps. `external` (may be null): per-node force (unit: N).
  /// Balls (`spheres`) are obstacles (particle coupling): XPBD cloths project their nodes out of
  /// them after every sweep, inside the solve; explicit cloths after the step (collideSpheres).
  /// Returns per sphere the impulse of the nodes on it over the step (unit: N s).
  std::vector<Eigen::Vector3d> step(double t, double dt, const Eigen::Vector3d& g, const cl::Buffer* external,
                                    const std::vector<SphereCollider>& spheres = {});
  /// Contact with balls (particle coupling): every free node inside a sphere goes to its surface and
  /// loses its velocity into the sphere relative to it (inelastic), with Coulomb friction. Returns per sphere
  /// the impulse the nodes exert on it (unit: N s), summed over the nodes in order (deterministic).
  std::vector<Eigen::Vector3d> collideSpheres(const std::vector<SphereCollider>& spheres);
  /// The cutters' closed surfaces in their body frames (uploaded once; scene order of the cutters).
  void setCutters(const std::vector<const TriMesh*>& meshes);
  /// Cutting: every unbroken spring whose segment crosses a cutter's surface (or lies inside it)
  /// breaks for good, one work-item per spring (kernels/cloth.cl, cloth_cut). `poses`: one per
  /// cutter given to setCutters, in that order.
  void cut(const std::vector<CutterPose>& poses);
  /// Substeps the explicit solver took in the last step().
  int lastSubsteps() const { return last_substeps_; }
  /// Substeps the XPBD solver takes in a step of dt (unit: s): ceil(dt / ClothModel::xpbd_dt_limit),
  /// 0 without an XPBD cloth.
  int xpbdSubsteps(double dt) const;
  /// Substeps the XPBD solver took in the last step() (ClothModel::xpbd_dt_limit).
  int lastXpbdSubsteps() const { return last_xpbd_substeps_; }
  /// Positions (w = inverse mass) and velocities of all nodes.
  void read(std::vector<Eigen::Vector4f>& x, std::vector<Eigen::Vector4f>& v);
  /// Overwrites positions and velocities of all nodes (the host-side contact with bodies).
  void write(const std::vector<Eigen::Vector4f>& x, const std::vector<Eigen::Vector4f>& v);
  std::vector<uint32_t> readBroken();
  /// Energies, strain and anchor force of cloth `c` now.
  ClothReport report(std::size_t c, const Eigen::Vector3d& g);
  /// DFSPH's strong coupling: each node's response to a force within a step of dt (unit: s), its
  /// springs implicit (kernels/cloth.cl, cloth_node_response): the rows of M^-1, 3 float4 per node
  /// into `out` (unit: 1/kg; zero for anchored nodes).
  void nodeResponse(double dt, cl::Buffer& out);
  /// DFSPH's added mass of wet nodes (Simulation::clothAddedMass): with it on, the XPBD step moves
  /// node i as m_i + M_i (addedMass(): M_i per node, unit: kg, 0 for none, written by the caller
  /// before each step), nodeResponse and the balls' impulses count M_i, and each step leaves the
  /// momentum M_i (v' - v) in addedMassImpulse() (float4 per node, unit: N s) for the fluid.
  void setAddedMass(bool on) { added_mass_ = on; }
  cl::Buffer& addedMass() { return fict_; }
  cl::Buffer& addedMassImpulse() { return impulse_M_; }
  /// addedMassImpulse() summed over the nodes in order: what the fluid has yet to take (the last
  /// step's, given before the next step's solves, and a dry node's until it is wet; unit: N s). Zero
  /// without the added mass.
  Eigen::Vector3d pendingAddedMassMomentum();
  /// DFSPH's strong coupling: what this step would do to each node's velocity without the fluid
  /// (gravity, springs, anchors, damping, balls, the domain's walls: step() with no external force
  /// and no tearing), v' - v per node into `out` (float4, unit: m/s). The cloth is left as it was.
  void dryVelocityChange(double t, double dt, const Eigen::Vector3d& g, const std::vector<SphereCollider>& spheres,
                         cl::Buffer& out);
  const cl::Buffer& positions() const { return x_[cur_]; }
  /// The spring table (ClothModel's row_start, spring, other, prm) and the broken flags.
  const cl::Buffer& rowStart() const { return row_start_; }
  const cl::Buffer& springs() const { return spring_; }
  const cl::Buffer& others() const { return other_; }
  const cl::Buffer& springParams() const { return prm_; }
  const cl::Buffer& brokenSprings() const { return broken_; }
  const cl::Buffer& velocities() const { return v_[cur_]; }
  /// Per node 1 if its cloth is stepped by XPBD, 0 if explicit (uint).
  const cl::Buffer& xpbdNodes() const { return is_xpbd_; }
  std::size_t bytes() const { return bytes_; }

 private:
  cl::Buffer make(std::size_t bytes);
  template <class T>
  cl::Buffer upload(const std::vector<T>& data);
  void explicitSubstep(double t, float dt, const Eigen::Vector4f& g, const cl::Buffer& fext);
  void xpbdStep(double t, float dt, const Eigen::Vector4f& g, const cl::Buffer& fext, uint32_t n_spheres);
  void uploadSpheres(const std::vector<SphereCollider>& spheres);
  void tear();
  void uploadTracks(double t_end);

  const ClothModel& m_;
  ClContext& cl_;
  KernelSet& k_;
  std::size_t bytes_ = 0;
  uint32_t n_ = 0, ns_ = 0, max_iterations_ = 0;
  int cur_ = 0;
  int last_substeps_ = 0, last_xpbd_substeps_ = 0;
  double last_dt_ = 0.0;  // the last XPBD (sub)step's length, for its constraint forces (unit: s)
  bool any_explicit_ = false, any_xpbd_ = false;
  bool dry_ = false;              // inside dryVelocityChange: no tearing, no impulses read
  bool added_mass_ = false;       // DFSPH's added mass of wet nodes (setAddedMass)
  cl::Buffer fict_, impulse_M_, vstart_;  // per node: M (kg, 0: none), M (v' - v) (N s), v at the step's start
  cl::Buffer dry_x_, dry_v_, dry_lo_;  // the state kept over a dry step
  cl::Buffer x_rest_, track_;  // placed positions; tracks at the step's end (offset, velocity) per track
  // Explicit solver: the low parts of the positions (x = x_[cur_] + xlo_[lo_cur_], an unevaluated
  // float sum, kernels/cloth.cl), ping-ponged by its substeps only (unit: m); zero elsewhere.
  cl::Buffer xlo_[2];
  int lo_cur_ = 0;
  std::vector<Eigen::Vector4f> track_host_;
  cl::Buffer x_[2], v_[2], prev_, mass_, drag_, anchor_, row_start_, spring_, other_, ends_, prm_, broken_, slot_,
      lambda_, zero_force_, is_xpbd_, iters_, spheres_, impulse_, impulse_sum_, shift_;
  // Cutters: triangles (3 corners each, body frame), per cutter (first triangle, count) and pose.
  cl::Buffer cut_tri_, cut_range_, cut_pose_;
  uint32_t n_cutters_ = 0;
  std::size_t sphere_capacity_ = 0;
  std::size_t fused_local_ = 1;  // work-items of the fused XPBD solve (cloth_xpbd_solve)
  uint32_t fused_max_nodes_ = kFusedMaxNodes;

 public:
  /// Up to this many nodes (all cloths and soft bodies) the XPBD solve of a step is one launch
  /// (cloth_xpbd_solve, one work-group); above it, one launch per colour and sweep, which spreads
  /// over all compute units (unit: 1).
  static constexpr uint32_t kFusedMaxNodes = 1u << 16;
  /// Changes that limit (tests: the two paths give bitwise equal results).
  void setFusedMaxNodes(uint32_t n) { fused_max_nodes_ = n; }
};

}  // namespace sph::cloth
