// SceneSpec: the plain description of a scene, as the user wrote it, with defaults filled in.
//
// io::loadScene() turns a YAML file into a SceneSpec (validating every key against the schema
// table in io/schema.cpp); core::compile() turns a SceneSpec into an immutable Model and the
// initial State. Nothing here is derived: derived quantities (smoothing length, particle mass,
// boundary volumes, stage mask) belong to the Model.
//
// Units are SI throughout (m, s, kg); Z is up. Every default here must match the schema table.
#pragma once

#include "core/mesh.h"

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <limits>
#include <string>
#include <vector>

namespace sph {

/// Where a value came from in a scene file, for errors raised after loading (1-based; 0 = unknown).
struct SourceLoc {
  std::string file;
  int line = 0;
  int col = 0;
  std::string str() const;  ///< "file:line:col" (or just "file" when line is unknown)
};

enum class KernelType { CubicSpline, WendlandC2 };
enum class EquationOfState { Linear, Tait };
enum class ViscosityModel { Artificial, Laminar };
/// Viscous coupling of the fluid with moving rigid bodies (Akinci et al. 2012 eq. 11 has its own
/// coefficient for it): the liquid's real viscosity, or the fluid's own (numerical) model.
enum class BodyViscosity { Fluid, Physical };
/// What a moving body's pressure force does with the ambient pressure around it (fluid.body_ambient_pressure;
/// WCSPH and DFSPH's extrapolated walls).
enum class BodyAmbientPressure { Auto, Subtract, Keep };
/// Velocity a boundary particle carries in the viscous term between fluid and boundary: its own
/// (the wall's or body's) velocity, or the no-slip ghost velocity 2 v_wall - v~ of Adami, Hu &
/// Adams 2012 (eq. 22-23; kernels/viscosity.cl); auto = ghost wherever the term is the laminar
/// (physical) one, the wall's velocity for the artificial (numerical) term.
enum class BoundaryVelocity { Auto, Ghost, Wall };
enum class TimeStepControl { Subdivide, Warn };
enum class NumericalPolicy { Warn, Abort };
enum class NozzleShape { Rectangle, Circle };
enum class BodyShape { Mesh, Sphere, Box, Cylinder, Capsule };
enum class MotionType { None, Constant, Keyframes };
enum class ClothSolver { Xpbd, Explicit };
enum class AnchorType { Corners, Edge, Node, Box };
enum class ClothEdge { XMin, XMax, YMin, YMax, ZMin, ZMax };  ///< z_min / z_max: soft bodies only
enum class FluidSolver { Wcsph, Dfsph };
/// How DFSPH's walls take pressure (core/dfsph.h): mirrored (p_b = p_i, increments >= 0),
/// Akinci's single term (p_b = 0, pressures projected to >= 0: the reference implementation's) or
/// extrapolated (p_b from the fluid around the wall particle, Adami et al. 2012 eq. 27, in each
/// projected Jacobi iteration, as WCSPH's walls; Band et al. 2018 for IISPH).
enum class DfsphWalls { Mirrored, Single, Extrapolated };
/// How DFSPH couples boundary particles that move (cloth and soft-body nodes, rigid bodies): strong,
/// they move under the pressure inside the solves' iterations (kernels/dfsph.cl, dfsph_node_accel
/// and dfsph_body_accel); staggered, they answer the solves' pressure in their own step after (a
/// light sheet between two water layers blows up: the added-mass instability; a light body needs
/// the fictitious mass body_added_mass).
enum class DfsphCoupling { Strong, Staggered };
/// DFSPH's laminar viscosity: explicit (the step is bound by 0.125 h^2 / nu, Morris et al. 1997) or
/// implicit, a conjugate-gradient solve of backward Euler with Morris' operator L (Weiler et al. 2018
/// solve implicitly too, with their own operator), which lifts that bound. auto (the default): implicit where
/// the explicit bound would be shorter than fluid.dfsph.max_time_step and the scene allows it, explicit
/// otherwise (core/model.cpp, resolveViscositySolve; the compiled model holds the choice).
enum class ViscositySolve { Explicit, Implicit, Auto };
/// The implicit viscosity takes cloth, and soft bodies lighter than the liquid, only with their XPBD step split
/// into substeps of at most this (their automatic max_time_step chooses it; io/scene_loader.cpp refuses a longer
/// one). In one step per 5 ms fluid step light hammocks and slabs swung or blew up in 0.1 m^2/s syrup; at 0.5 ms
/// they rest as with the explicit solve (docs/dfsph.md, session 38). Longer substeps were not measured (unit: s).
constexpr double kImplicitViscosityXpbdStep = 0.0005;

struct SimulationSpec {
  double duration = 2.0;                        ///< simulated time to run (unit: s)
  double frame_rate = 60.0;                     ///< output frames per simulated second (unit: 1/s)
  int substeps = 4;                             ///< time steps per frame before CFL subdivision (unit: 1)
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};     ///< gravitational acceleration (unit: m/s^2)
  double gravity_ramp = 0.0;                    ///< gravity ramps from 0 to full over this time (unit: s)
  /// Before t = 0 the fluid settles this long under gravity (ramped in over the first quarter) with
  /// its velocities damped, bodies and cloth held; then time starts at 0 with the fluid at rest
  /// (Simulation::settle; 0 = start from the blocks' lattice) (unit: s).
  double settle_time = 0.0;
  double settle_damping = 0.2;                  ///< time constant of the settle's velocity damping (unit: s)
  KernelType kernel = KernelType::CubicSpline;  ///< smoothing kernel
  double support_ratio = 2.0;                   ///< kernel support radius / particle spacing (unit: 1)
  TimeStepControl time_step_control = TimeStepControl::Subdivide;  ///< what to do when dt > CFL limit
  double cfl = 0.4;                             ///< Courant number: dt <= cfl * h / (c0 + |v|max) (unit: 1)
  /// Rigid bodies' contacts and positions in substeps of at most this within each step, the step's forces
  /// applied once (Simulation::integrateBodies; 0 = one per step). At long steps (DFSPH's, or a rigid-only
  /// scene's frame substeps) one contact per step damps rolling (docs/forces.md, session 40) (unit: s).
  double contact_step = 0.0;
  NumericalPolicy numerical_errors = NumericalPolicy::Abort;  ///< NaN, escapes, CFL violations
  SourceLoc loc;
};

/// Index of each wall in DomainSpec::closed.
enum Wall { XMin = 0, XMax, YMin, YMax, ZMin, ZMax };

struct DomainSpec {
  Eigen::Vector3d min{0.0, 0.0, 0.0};  ///< lower corner of the domain box (unit: m)
  Eigen::Vector3d max{1.0, 1.0, 1.0};  ///< upper corner of the domain box (unit: m)
  /// Which walls are closed (x_min, x_max, y_min, y_max, z_min, z_max). Default: all but z_max.
  std::array<bool, 6> closed{true, true, true, true, true, false};
  int boundary_layers = 2;             ///< layers of boundary particles behind each closed wall (unit: 1)
  SourceLoc loc;
};

struct PhaseSpec {
  std::string name;                            ///< referenced by blocks and inflows
  double rest_density = 1000.0;                ///< (unit: kg/m^3)
  double viscosity = 1.0e-6;                   ///< kinematic viscosity, used by the laminar model (unit: m^2/s)
  Eigen::Vector3d colour{0.2, 0.4, 0.9};       ///< linear RGB in [0,1]
  SourceLoc loc;
};

/// An axis-aligned box filled with particles on a cubic lattice at the particle spacing.
struct BlockSpec {
  std::string phase;                           ///< phase name (default: the first phase)
  Eigen::Vector3d min{0.0, 0.0, 0.0};          ///< (unit: m)
  Eigen::Vector3d max{0.0, 0.0, 0.0};          ///< (unit: m)
  Eigen::Vector3d velocity{0.0, 0.0, 0.0};     ///< initial velocity (unit: m/s)
  SourceLoc loc;
};

/// A nozzle that emits layers of particles at the particle spacing while active.
struct InflowSpec {
  std::string name;
  std::string phase;                                   ///< phase name (default: the first phase)
  NozzleShape shape = NozzleShape::Circle;
  Eigen::Vector3d position{0.0, 0.0, 0.0};             ///< nozzle centre (unit: m)
  Eigen::Vector3d direction{0.0, 0.0, -1.0};           ///< emission direction (normalised on compile)
  double radius = 0.05;                                ///< circle nozzle radius (unit: m)
  double width = 0.1;                                  ///< rectangle nozzle width (unit: m)
  double height = 0.1;                                 ///< rectangle nozzle height (unit: m)
  double speed = 1.0;                                  ///< emission speed (unit: m/s)
  double start = 0.0;                                  ///< emission start time (unit: s)
  double stop = std::numeric_limits<double>::infinity();  ///< emission stop time (unit: s)
  SourceLoc loc;
};

/// Settings of the divergence-free SPH solver (Bender & Koschier 2017), used with solver dfsph.
/// Defaults as the reference implementation (SPlisHSPlasH): density error 0.05 %, divergence 0.1 %.
struct DfsphSpec {
  double density_error = 5.0e-4;     ///< bound on the average density error (rho - rho0) / rho0 per step (unit: 1)
  double divergence_error = 1.0e-3;  ///< bound on the average density change per step dt (D rho / Dt) / rho0 (unit: 1)
  int min_iterations = 2;            ///< density solve: iterations at least (unit: 1)
  int max_iterations = 100;          ///< density solve: iterations at most; a step that stops here is counted (unit: 1)
  int divergence_min_iterations = 1; ///< divergence solve: iterations at least (unit: 1)
  int divergence_max_iterations = 100;  ///< divergence solve: iterations at most (unit: 1)
  bool divergence_solve = true;      ///< make the velocity field divergence-free each step (B&K 2017 Alg. 2)
  DfsphWalls walls = DfsphWalls::Extrapolated;  ///< wall pressure and Jacobi variant (see DfsphWalls)
  bool warm_start = true;            ///< start each solve from the previous step's pressure
  /// the density solve's warm start filtered: the last pressure's particle-scale part (its deviation from
  /// the neighbours' Shepard average, hydrostatic part exact) scaled by 1 - beta. A calm shallow tub with
  /// little viscosity, restarted from the full pressure (0), kept moving at 7x the iterations; 0.5 calms
  /// it, but alone a narrow column at rest can swing with it and a deep tank with a sinking ball blew up
  /// (with warm_average 0.5 both stay stable); neighbours of the same phase only. 0 = off by default: it
  /// costs iterations at tight density bounds (kernels/dfsph.cl, dfsph_warm_filter; docs/dfsph.md, sessions
  /// 28 and 29); walls single or extrapolated (unit: 1)
  double warm_smoothing = 0.0;
  /// the density solve's warm start averaged over two steps: p + gamma (p_prev - p), p the last step's
  /// pressure and p_prev the one before. The part the last solve added for its own step's error, which a
  /// full restart applies twice, enters at 1 - gamma; what every step needs (a column's weight, a body at
  /// rest) is in both. 0 = the last pressure alone (kernels/dfsph.cl, dfsph_warm_average; docs/dfsph.md,
  /// session 29); walls single or extrapolated (unit: 1)
  double warm_average = 0.0;
  /// the same average in the density solves of steps at rest (the two-level solve's rest test: the fastest
  /// particle moved less than coarse_rest_travel dx in the last step), where the larger of the two applies.
  /// Restarted in full at rest, the last solve's push for its own error returns a step late as a period-2
  /// swing that the loose default bound leaves in place. The 0.2 m tank at rest, 24 small changes to its
  /// settings, two builds that round differently (48 runs): calm from 1 s (< 95 Pa between steps) in 23 with
  /// 0, 47 with 0.5, 48 with 0.6 and 0.75, at 2.0-2.2 density iterations per step against 2.8-3.1; at the
  /// tight bound 1e-5 (24 runs) steps above the bound in 4 runs with 0, none with 0.6, 6 of 12 with 0.75
  /// (docs/dfsph.md, session 47). Moving flows keep the full restart (the 50k dam break took 6 % more
  /// iterations per step with the average); 0 = off. It takes margin from the pressure's own step scale:
  /// the deep column under pressure_cfl 0.7 swung with it (session 47), under 0.5 (the default) it rests
  /// (session 50) (unit: 1)
  double warm_average_rest = 0.6;
  double relaxation = 0.5;           ///< Jacobi relaxation omega of both solves' pressure increments (unit: 1)
  /// Chebyshev semi-iteration on the density solve's relaxed Jacobi iterates (Golub & Varga 1961; Wang 2015
  /// for position-based dynamics): rho is the estimated spectral radius of the relaxed iteration, and after
  /// the first iteration each iterate is x_{k-1} + w_k (x_jac - x_{k-1}), w_2 = 2 / (2 - rho^2),
  /// w_{k+1} = 4 / (4 - rho^2 w_k), projected on p >= 0. In moving steps only (the fastest particle moved at least
  /// 0.1 dx in the last step, core/dfsph.cpp kChebyshevTravel; a step at rest keeps plain Jacobi and the two-level
  /// solve); a coarse correction restarts the sequence. 0 = off (unit: 1)
  double chebyshev = 0.9;
  double divergence_chebyshev = 0.7;  ///< the same for the divergence solve (unit: 1)
  /// the laminar viscosity explicit (the step bound 0.125 h^2 / nu applies) or implicit (a conjugate-gradient
  /// solve each step, no viscous step bound; kernels/viscosity.cl, viscosity_cg_*)
  ViscositySolve viscosity_solve = ViscositySolve::Auto;
  /// implicit viscosity: the solve stops when its preconditioned residual is this fraction of the step's first
  /// one (its explicit viscous increment), sqrt(r.z / r0.z0) (unit: 1)
  double viscosity_tolerance = 1.0e-3;
  int viscosity_max_iterations = 200;  ///< implicit viscosity: conjugate-gradient iterations at most per step (unit: 1)
  int coarse_interval = 4;           ///< two-level solve: a coarse-grid correction after the first iteration of the density solve at rest (and every n iterations after from coarse_rest_start while above its bound), and every n Jacobi iterations of a stalled solve from coarse_start (if > 0); 0 = off, plain Jacobi (kernels/dfsph_coarse.cl) (unit: 1)
  int coarse_start = 0;              ///< two-level solve: a solve still above its bound after k0 iterations takes a correction then and every coarse_interval after; 0 = never (unit: 1)
  double coarse_rest_travel = 0.1;   ///< two-level solve: a step whose fastest particle moved less than this many spacings dx in the last step is at rest: its density solve takes a correction after the first iteration (unit: 1)
  int coarse_reuse = 0;              ///< two-level solve: an assembled coarse operator serves the corrections of this many steps while the fastest particle moves less than 0.25 dx and the step changes by less than 25 % (K ~ dt^2 scaled); 0 = assembled for every correction (core/dfsph_coarse.cpp, session 24) (unit: 1)
  int coarse_rest_start = 1;         ///< two-level solve: a density solve at rest (coarse_rest_travel) still above its bound after this many iterations takes another correction then and every coarse_interval after; 0 = never (unit: 1)
  /// Courant number: dt <= cfl * dx / |v|max. 0.8, twice the reference's 0.4, since session 50: with the
  /// Chebyshev semi-iteration (session 48) the longer step costs fewer iterations than it saves steps, and
  /// with pressure_cfl (below) it stays stable (docs/dfsph.md, session 50) (unit: 1)
  double cfl = 0.8;
  double max_time_step = 0.005;      ///< largest step (unit: s)
  /// adaptive step from the density solve's work: a step whose density solve took more than n
  /// iterations bounds the next steps by 0.9 of its length, one that took fewer than n / 2 lets the
  /// bound grow by 1.1 per step (SPlisHSPlasH's "CFL - iterations" rule, n = 10 there); 0 = off (unit: 1)
  int step_iterations = 0;
  /// step bound from the largest pressure: dt <= pressure_cfl * dx / sqrt(max_i p_i / rho_i). The
  /// pressure acts on the particle-scale (non-compressive) modes of the lattice, which the density
  /// solve does not hold and the step integrates explicitly: a resting column of depth H bounces once
  /// dt sqrt(g H) / dx passes ~0.9 (measured, docs/dfsph.md session 15); 0.7 holds deep columns at
  /// rest. 0.5 by default since session 50: at cfl 0.8 a 28 cm tank filling under its gravity ramp blew
  /// up without it (15 m/s at 0.6 s), and 0.5 leaves the margin the warm start averaged at rest
  /// (warm_average_rest) takes: the 0.28 m column rested in 3 of 3 ramps with both (0.6: 1 of 3; 0.7:
  /// swung, session 47); the 50k dam break takes 193 steps instead of 146 without it, 17 % more wall
  /// time (docs/dfsph.md, session 50); 0 = off (unit: 1)
  double pressure_cfl = 0.5;
  /// dynamic bodies' fictitious mass C rho0 V in their translation (Baek & Karniadakis 2012), and the
  /// inertia (M / m) I in their rotation (session 16), against the added-mass instability of light
  /// bodies; its force and torque count in the body's fluid force and torque, the force's reaction goes
  /// to the fluid near the body (momentum conserved; the torque's does not, its sum over a run is one
  /// step's worth); 0.5, a sphere's added mass, by default; 0 = off (unit: 1)
  double body_added_mass = 0.5;
  DfsphCoupling cloth_coupling = DfsphCoupling::Strong;  ///< see DfsphCoupling
  /// dynamic rigid bodies: strong (the default since session 26), each free dynamic body's velocity
  /// inside the solves' iterations (Gissler et al. 2019's interlinked coupling; then without the
  /// fictitious mass), or staggered, the body's step after the solves with the fictitious mass (the
  /// default before: cheaper, and a floating body's force swings 20x more); see DfsphCoupling
  DfsphCoupling body_coupling = DfsphCoupling::Strong;
  /// with strong body coupling: a solve goes on until each free body's acceleration is within this of
  /// the one its current pressures give, |F / m - a| + R |I^-1 T - alpha| (R its reach; kernels/dfsph.cl,
  /// dfsph_body_accel), besides the average density error (unit: m/s^2)
  double body_error = 0.1;
  /// with strong body coupling and the two-level solve: each free body's six degrees of freedom take part
  /// in the coarse-grid correction (its Schur term in the coarse operator, kernels/dfsph_coarse.cl), so a
  /// correction moves the body with the pressure it finds; false: a correction sees the bodies held and
  /// is made only while the fluid's own error is above its bound (session 23) (session 25)
  bool body_coarse = true;
  /// with strong cloth coupling, in steps the cloth takes in XPBD substeps: each wet free node (fluid
  /// within H) moves with an added mass C rho0 V_k (V_k the fluid volume its boundary particle stands
  /// for) in its own step, the reaction going to the fluid near it (Simulation::clothAddedMass); 1 by
  /// default; 0 = off (unit: 1)
  double cloth_added_mass = 1.0;
  SourceLoc loc;
};

struct FluidSpec {
  FluidSolver solver = FluidSolver::Wcsph;  ///< pressure solver: weakly compressible or divergence-free SPH
  DfsphSpec dfsph;                          ///< settings of the dfsph solver
  double particle_spacing = 0.02;                              ///< lattice spacing dx (unit: m)
  EquationOfState equation_of_state = EquationOfState::Linear; ///< p = k (rho - rho0), or Tait
  double speed_of_sound = 0.0;     ///< c0; 0 = automatic, 10 * sqrt(2 |g| H) over the fluid height (unit: m/s)
  ViscosityModel viscosity_model = ViscosityModel::Artificial;
  double artificial_viscosity = 0.05;  ///< Monaghan alpha, used by the artificial model (unit: 1)
  BodyViscosity body_viscosity = BodyViscosity::Fluid;  ///< fluid-body viscous term: the fluid's model, or the phase viscosity (laminar form)
  BodyAmbientPressure body_ambient_pressure = BodyAmbientPressure::Auto;  ///< auto (session 33): subtract with WCSPH, keep with DFSPH; subtract = a wholly wetted body's pressure force without the ambient pressure's share of its sampled surface's closure error
  BoundaryVelocity boundary_velocity = BoundaryVelocity::Auto;  ///< boundary particles' velocity in the viscous term: no-slip ghost (Adami 2012) or the wall's own
  double colour_diffusion = 0.0;       ///< colour diffusion coefficient; 0 = none (unit: m^2/s)
  bool clamp_negative_pressure = true; ///< clamp p >= 0 (avoids tensile instability at free surfaces)
  double background_pressure = 0.0;    ///< WCSPH, every wall closed: added to the equation of state (Morris, Fox & Zhu 1997) (unit: Pa)
  long max_particles = 0;              ///< particle budget; 0 = automatic (unit: 1)
  std::vector<PhaseSpec> phases;
  std::vector<BlockSpec> blocks;
  std::vector<InflowSpec> inflows;
  SourceLoc loc;
};

/// One key of a keyframed motion: the pose of the body origin at `time`.
struct KeyframeSpec {
  double time = 0.0;                                ///< (unit: s); strictly increasing along the list
  Eigen::Vector3d position{0.0, 0.0, 0.0};          ///< world position of the body origin (unit: m)
  Eigen::Vector3d orientation_axis{0.0, 0.0, 1.0};  ///< rotation axis (normalised on compile)
  double orientation_angle = 0.0;                   ///< rotation about the axis (unit: deg)
  SourceLoc loc;
};

/// A scripted (kinematic) motion, followed whatever acts on the body. With type `constant` the
/// body translates at `velocity` and turns at `angular_velocity` about its centre of mass. With
/// type `keyframes` its pose follows a C1 curve through `keyframes` (core/rigid.h, keyframePose):
/// it holds the first key's pose before the first key and the last key's pose after the last.
struct MotionSpec {
  MotionType type = MotionType::None;
  Eigen::Vector3d velocity{0.0, 0.0, 0.0};          ///< (unit: m/s)
  Eigen::Vector3d angular_velocity{0.0, 0.0, 0.0};  ///< world frame (unit: rad/s)
  std::vector<KeyframeSpec> keyframes;              ///< type keyframes: at least 2, times strictly increasing
};

/// A rigid body: a closed surface (an OBJ mesh or a primitive) placed in the world.
/// Body frame: the mesh's (or primitive's) own coordinates, scaled by `scale`; its pose in the
/// world is x_world = position + R(orientation) * (scale * x_body). Orientation is a rotation of
/// `orientation_angle` degrees about `orientation_axis` (right-handed).
/// Kinds: static (dynamic false, no motion), kinematic (motion.type constant or keyframes), dynamic (dynamic true).
struct RigidBodySpec {
  std::string name;                                 ///< unique; names the output files
  BodyShape shape = BodyShape::Sphere;
  std::string mesh;                                 ///< OBJ file for shape mesh (absolute after loading)
  double radius = 0.05;                             ///< sphere, cylinder, capsule radius (unit: m)
  Eigen::Vector3d size{0.1, 0.1, 0.1};              ///< box edge lengths along the body axes (unit: m)
  double height = 0.1;                              ///< cylinder length; capsule distance between cap centres (unit: m)
  Eigen::Vector3d position{0.0, 0.0, 0.0};          ///< where the body origin goes (unit: m)
  Eigen::Vector3d orientation_axis{0.0, 0.0, 1.0};  ///< rotation axis (normalised on compile)
  double orientation_angle = 0.0;                   ///< rotation about the axis (unit: deg)
  double scale = 1.0;                               ///< uniform scale of the shape (unit: 1)
  double density = 0.0;                             ///< 0 = not given; exactly one of density, mass (unit: kg/m^3)
  double mass = 0.0;                                ///< 0 = not given (unit: kg)
  bool dynamic = false;                             ///< moved by forces (true) or static / scripted (false)
  double hold_until = 0.0;                          ///< dynamic: held still at its initial pose until this time, then released (unit: s)
  Eigen::Vector3d velocity{0.0, 0.0, 0.0};          ///< initial velocity of the centre of mass (unit: m/s)
  Eigen::Vector3d angular_velocity{0.0, 0.0, 0.0};  ///< initial angular velocity, world frame (unit: rad/s)
  double friction = 0.5;                            ///< Coulomb friction coefficient for contact (unit: 1)
  double restitution = 0.2;                         ///< normal restitution for contact (unit: 1)
  Eigen::Vector3d colour{0.7, 0.7, 0.7};            ///< linear RGB in [0,1]
  bool grabbable = false;                           ///< the haptic device may grab it
  bool cutter = false;                              ///< a blade: breaks every cloth spring that crosses its surface
  MotionSpec motion;                                ///< scripted motion (kinematic bodies)
  SourceLoc loc;
  SourceLoc mesh_loc;                               ///< where `mesh` was given (errors raised after loading)
  TriMesh mesh_data;                                ///< shape mesh: the welded, closed OBJ (filled by io::loadScene; not a key)
};

/// The fluid surface, meshed per output frame (core/isosurface.h). The stage runs only when the
/// scene asks for it: writing the `output.isosurface` section turns it on (enabled then defaults
/// to true), a scene without the section pays nothing.
struct IsosurfaceSpec {
  bool enabled = false;        ///< mesh the surface each output frame (the loader sets true when the section is given)
  double spacing = 0.0;        ///< surface grid spacing; 0 = automatic, a fixed fraction of dx (unit: m)
  double iso = 0.5;            ///< surface value of the normalised field sum_j V0 W (1 inside, 0 outside) (unit: 1)
  bool vertex_colours = false; ///< per-vertex colour from the particles' colour field (else none)
  bool obj = true;             ///< write fluid_<phase>_%04d.obj (Z up, metres, with normals)
  bool vdb = false;            ///< write the surface field as fluid_%04d.vdb (grid density, per phase density_<phase>)
  bool vdb_level_set = false;  ///< add a narrow-band level set 'surface' to each .vdb
  SourceLoc loc;
};

struct OutputSpec {
  std::string directory;      ///< output folder; empty = ./out/<scene stem>; relative to the scene file
  bool particles = true;      ///< write particles.h5part
  bool step_forces = false;   ///< write forces.csv: every time step's fluid force and torque on each moving body
  IsosurfaceSpec isosurface;
  SourceLoc loc;
};

/// One key of a keyframed cloth anchor: the anchored nodes' displacement from where they were
/// placed, at `time`. Between keys the offset is linear in time; before the first key it is the
/// first key's offset, after the last the last key's (held).
struct AnchorKeyframeSpec {
  double time = 0.0;                                ///< (unit: s)
  Eigen::Vector3d offset{0.0, 0.0, 0.0};            ///< displacement from the placed position, world frame (unit: m)
  SourceLoc loc;
};

/// One set of anchored (pinned) cloth nodes. Anchored nodes have infinite mass: they follow their
/// scripted motion (constant velocity, or keyframes) whatever the springs and the fluid do.
struct ClothAnchorSpec {
  AnchorType type = AnchorType::Corners;            ///< corners (all four; a soft body's eight), edge, node (i, j[, k]) or box (min, max)
  ClothEdge edge = ClothEdge::YMax;                 ///< type edge: which edge of the rectangle (cloth frame); a soft body: which side face (body frame)
  int i = 0;                                        ///< type node: node index along the cloth (soft body) x axis (0-based) (unit: 1)
  int j = 0;                                        ///< type node: node index along the cloth (soft body) y axis (0-based) (unit: 1)
  int k = 0;                                        ///< type node, soft bodies: lattice index along the body z axis (0-based) (unit: 1)
  Eigen::Vector3d min{0.0, 0.0, 0.0};               ///< type box: lower corner, world frame (unit: m)
  Eigen::Vector3d max{0.0, 0.0, 0.0};               ///< type box: upper corner, world frame (unit: m)
  Eigen::Vector3d velocity{0.0, 0.0, 0.0};          ///< velocity of the anchored nodes until `stop` (unit: m/s)
  double stop = std::numeric_limits<double>::infinity();  ///< the anchors stop moving at this time (unit: s)
  std::vector<AnchorKeyframeSpec> keyframes;        ///< instead of velocity: a piecewise-linear path, times strictly increasing
  SourceLoc loc;
};

/// A rectangular cloth: a mass-spring net of resolution_x x resolution_y nodes on a regular grid
/// in its own xy plane, centred on its origin; x_world = position + R(axis, angle) x_cloth.
/// Springs (Provot 1995): stretch between grid neighbours, shear along cell diagonals, bend between
/// nodes two apart. Every node carries the same mass, areal_density * width * length / nodes.
struct ClothSpec {
  std::string name;                                 ///< unique; names the output files
  double width = 0.1;                               ///< extent along the cloth x axis (unit: m)
  double length = 0.1;                              ///< extent along the cloth y axis (unit: m)
  int resolution_x = 11;                            ///< nodes along x; 1 = a chain along y (unit: 1)
  int resolution_y = 11;                            ///< nodes along y; 1 = a chain along x (unit: 1)
  Eigen::Vector3d position{0.0, 0.0, 0.0};          ///< world position of the cloth centre (unit: m)
  Eigen::Vector3d orientation_axis{0.0, 0.0, 1.0};  ///< rotation axis (normalised on compile)
  double orientation_angle = 0.0;                   ///< rotation about the axis (unit: deg)
  double areal_density = 0.2;                       ///< mass per area (unit: kg/m^2)
  double stretch_stiffness = 1000.0;                ///< spring constant of each stretch spring (unit: N/m)
  double shear_stiffness = 100.0;                   ///< spring constant of each shear spring; 0 = none (unit: N/m)
  double bend_stiffness = 10.0;                     ///< spring constant of each bend spring; 0 = none (unit: N/m)
  double damping = 0.0;                             ///< dashpot along every spring (unit: N s/m)
  double air_damping = 0.0;                         ///< drag on every node's velocity, dv/dt = -air_damping v (unit: 1/s)
  ClothSolver solver = ClothSolver::Xpbd;           ///< xpbd (default, unconditionally stable) or explicit
  int iterations = 8;                               ///< xpbd: Gauss-Seidel sweeps per step (unit: 1)
  /// xpbd: a longer step is taken in equal substeps no longer than this; inf: one step; 0: automatic,
  /// from the heaviest dynamic ball and the lightest node, and at most kImplicitViscosityXpbdStep under the
  /// implicit viscosity (core/model.cpp) (unit: s). A fixed number
  /// of sweeps holds the springs less the longer the step: at 5 ms steps a heavy ball went through a
  /// sheet that holds it at 0.5 ms (docs/dfsph.md, session 18).
  double max_time_step = 0.0;
  double tear_strain = std::numeric_limits<double>::infinity();  ///< a spring breaks past this strain (unit: 1)
  double prestrain = 0.0;                           ///< placed stretched: rest length = placed length / (1 + prestrain) (unit: 1)
  Eigen::Vector3d colour{0.8, 0.3, 0.3};            ///< linear RGB in [0,1]
  std::vector<ClothAnchorSpec> anchors;             ///< pinned nodes
  std::string mesh;                                 ///< OBJ triangle mesh instead of the rectangle (relative to the scene file; absolute after loading); empty = rectangle
  SourceLoc mesh_loc;                               ///< where `mesh` was given
  TriMesh mesh_data;                                ///< the welded mesh in the cloth frame (filled by io::loadScene; not a key)
  /// Rectangle keys given with `mesh` (width, length, resolution_*, shear_stiffness), which a mesh
  /// cloth does not use: "file:line:col: key" each (filled by io::loadScene; not a key).
  std::vector<std::string> unused_keys;
  /// Whether the cloth is a triangle mesh (else the rectangle grid).
  bool isMesh() const { return !mesh_data.triangles.empty(); }
  /// Its node count: the mesh's vertices, or resolution_x x resolution_y (unit: 1).
  double nodeCount() const {
    return isMesh() ? double(mesh_data.positions.size()) : std::max(1.0, double(resolution_x)) * std::max(1.0, double(resolution_y));
  }
  SourceLoc loc;
};

/// A soft body (issue 11): a volumetric lattice of nodes joined by springs, a box (`size`) or a
/// closed OBJ mesh filled with the lattice; x_world = position + R(axis, angle) x_body. The nodes
/// are particles like a cloth's (core/cloth.h: the same spring table, solvers, coupling, tearing
/// and cutting). Springs: the edges, face diagonals and body diagonals of every lattice cell, their
/// stiffness mapped from young_modulus (core/cloth.h, softSpringStiffness).
struct SoftBodySpec {
  std::string name;                                 ///< unique among soft bodies; names the output files
  Eigen::Vector3d size{0.1, 0.1, 0.02};             ///< box extents along the body axes (unit: m); not used with `mesh`
  Eigen::Vector3d position{0.0, 0.0, 0.0};          ///< world position of the body centre (unit: m)
  Eigen::Vector3d orientation_axis{0.0, 0.0, 1.0};  ///< rotation axis (normalised on compile)
  double orientation_angle = 0.0;                   ///< rotation about the axis (unit: deg)
  double spacing = 0.0;                             ///< lattice spacing; 0 = the fluid's particle spacing dx (unit: m)
  double density = 1000.0;                          ///< mass per volume (unit: kg/m^3)
  double young_modulus = 1.0e5;                     ///< Young's modulus of the material, Poisson ratio 1/4 (unit: Pa)
  double damping = 0.0;                             ///< stiffness-proportional (Rayleigh) damping: dashpot c = damping x k per spring (unit: s)
  double air_damping = 0.0;                         ///< drag on every node's velocity, dv/dt = -air_damping v (unit: 1/s)
  ClothSolver solver = ClothSolver::Xpbd;           ///< xpbd (default, unconditionally stable) or explicit
  int iterations = 8;                               ///< xpbd: Gauss-Seidel sweeps per step (unit: 1)
  /// xpbd: a longer step is taken in equal substeps no longer than this; inf: one step; 0: automatic,
  /// from the heaviest dynamic ball and the lightest node, and at most kImplicitViscosityXpbdStep under the
  /// implicit viscosity when the body is lighter than the liquid (core/model.cpp) (unit: s). A fixed number
  /// of sweeps holds the springs less the longer the step: at 5 ms steps a heavy ball went through a
  /// sheet that holds it at 0.5 ms (docs/dfsph.md, session 18).
  double max_time_step = 0.0;
  double tear_strain = std::numeric_limits<double>::infinity();  ///< a spring breaks past this strain (unit: 1)
  double prestrain = 0.0;                           ///< placed stretched: rest length = placed length / (1 + prestrain) (unit: 1)
  Eigen::Vector3d colour{0.9, 0.7, 0.6};            ///< linear RGB in [0,1]
  std::vector<ClothAnchorSpec> anchors;             ///< pinned nodes: corners, edge (a face of the lattice), node (i, j, k) or box
  std::string mesh;                                 ///< closed OBJ mesh filled with the lattice (relative to the scene file; absolute after loading); empty = box
  SourceLoc mesh_loc;                               ///< where `mesh` was given
  TriMesh mesh_data;                                ///< the welded closed mesh in the body frame (filled by io::loadScene; not a key)
  bool isMesh() const { return !mesh_data.triangles.empty(); }
  SourceLoc loc;
};

/// A point probe: the fluid's pressure, density and velocity at a fixed point, by Shepard-normalised
/// kernel interpolation (core/probes.h).
struct PointProbeSpec {
  std::string name;                          ///< unique among probes and gauges; names its CSV columns
  Eigen::Vector3d position{0.0, 0.0, 0.0};   ///< (unit: m), inside the domain
  SourceLoc loc;
};

/// A water-height gauge: a vertical line from `position` up; it reads the height of the fluid
/// column standing on its foot (core/probes.h).
struct GaugeSpec {
  std::string name;                          ///< unique among probes and gauges; names its CSV column
  Eigen::Vector3d position{0.0, 0.0, 0.0};   ///< foot of the line (unit: m), inside the domain
  double length = 0.0;                       ///< length of the line; 0 = up to the domain's top (unit: m)
  SourceLoc loc;
};

/// Probes and gauges, sampled into probes.csv. A scene without the section runs no probe kernel.
struct ProbesSpec {
  double rate = 0.0;                         ///< samples per simulated second; 0 = every time step (unit: 1/s)
  std::vector<PointProbeSpec> points;
  std::vector<GaugeSpec> gauges;
  SourceLoc loc;
  bool any() const { return !points.empty() || !gauges.empty(); }
};

// --- Haptics ------------------------------------------------------------------------------------

enum class HapticBackend { Scripted, Simulated, Bridge };
enum class HapticSmoothing { Servo, RollingAverage };
enum class PathSegmentType { Line, Circle, Sine };

/// One piece of the scripted hand path (device frame, metres; haptics/trajectory.h).
struct PathSegmentSpec {
  PathSegmentType type = PathSegmentType::Line;
  double start = 0.0;                                ///< (unit: s)
  double end = 1.0;                                  ///< (unit: s)
  Eigen::Vector3d from{0.0, 0.0, 0.0};               ///< line start (unit: m)
  Eigen::Vector3d to{0.0, 0.0, 0.0};                 ///< line end (unit: m)
  Eigen::Vector3d centre{0.0, 0.0, 0.0};             ///< circle centre; sine centre (unit: m)
  double radius = 0.02;                              ///< circle radius (unit: m)
  Eigen::Vector3d axis{0.0, 0.0, 1.0};               ///< circle plane normal (unit: 1)
  double period = 1.0;                               ///< circle: one turn (unit: s)
  double phase = 0.0;                                ///< circle: angle at start (unit: rad)
  Eigen::Vector3d amplitude{0.01, 0.0, 0.0};         ///< sine sweep amplitude (unit: m)
  double f0 = 1.0;                                   ///< sine sweep start frequency (unit: Hz)
  double f1 = 1.0;                                   ///< sine sweep end frequency (unit: Hz)
  SourceLoc loc;
};

/// A point the hand passes at a time (device frame; straight lines between waypoints).
struct WaypointSpec {
  double time = 0.0;                                 ///< (unit: s)
  Eigen::Vector3d position{0.0, 0.0, 0.0};           ///< (unit: m)
  SourceLoc loc;
};

/// A button pressed or released.
struct ButtonEventSpec {
  double time = 0.0;                                 ///< (unit: s)
  int button = 0;                                    ///< 0 or 1
  bool pressed = true;
  SourceLoc loc;
};

/// The `haptics` section: a device grabs `grabbable` bodies (haptics/, ../shared/haptics.md). The
/// stage runs only when the section is present.
struct HapticsSpec {
  bool enabled = false;                              ///< set by the loader when the section is given
  HapticBackend backend = HapticBackend::Scripted;
  // Workspace mapping: x_scene = scale R(axis, angle) x_device + offset.
  double scale = 0.0;                                ///< 0 = automatic: largest domain extent / 0.15 m (unit: 1)
  Eigen::Vector3d rotation_axis{0.0, 0.0, 1.0};      ///< (unit: 1)
  double rotation_angle = 0.0;                       ///< (unit: deg)
  Eigen::Vector3d offset{0.0, 0.0, 0.0};             ///< scene point of the device origin; default the domain centre (unit: m)
  bool offset_given = false;                         ///< set by the loader when `offset` is written
  double gain = 1.0;                                 ///< force gain g: felt force = g x force on the body ("haptic strength") (unit: 1)
  double stiffness = 250.0;                          ///< coupling stiffness felt at the hand K_d (unit: N/m)
  double damping = 1.5;                              ///< coupling damping felt at the hand B_d (unit: N s/m)
  double damping_ratio = 0.9;                        ///< scene coupling damper B_s = 2 zeta sqrt(K_s m) (unit: 1)
  double reach = 0.05;                               ///< grab a body whose surface is this close to the target (unit: m)
  bool hold_orientation = true;                      ///< hold a grabbed body's orientation at the grab (angular spring, not felt)
  double peak_force = 3.0;                           ///< (unit: N)
  double continuous_force = 0.85;                    ///< limit on the 1 s RMS (unit: N)
  double ramp_time = 2.0;                            ///< start-up ramp (unit: s)
  double watchdog = 0.1;                             ///< oldest usable local model (unit: s)
  double lowpass = 25.0;                             ///< feed-forward low-pass cut-off (unit: Hz)
  bool passivity = true;                             ///< passivity observer and controller
  double servo_rate = 1000.0;                        ///< (unit: Hz)
  HapticSmoothing smoothing = HapticSmoothing::Servo;
  int rolling_window = 20;                           ///< rolling_average: frames averaged (unit: 1)
  // Simulated backend: the hand.
  double hand_mass = 0.15;                           ///< hand + end effector (unit: kg)
  double hand_stiffness = 300.0;                     ///< grip spring to the scripted target (unit: N/m)
  double hand_damping = 3.0;                         ///< grip damper (unit: N s/m)
  // Bridge backend: UDP on 127.0.0.1 to a running `sphaptics-bridge` (live runs only).
  int bridge_port = 47001;                           ///< the bridge listens here for LocalModels (unit: 1)
  int listen_port = 47002;                           ///< the simulation listens here for States (unit: 1)
  double bridge_timeout = 1.0;                       ///< no State for this long = device failure, exit 3 (unit: s)
  std::vector<PathSegmentSpec> path;                 ///< scripted path (device frame)
  std::vector<WaypointSpec> waypoints;               ///< scripted waypoints (device frame); used when `path` is empty
  std::vector<ButtonEventSpec> buttons;              ///< button events
  SourceLoc loc;
};

struct SceneSpec {
  std::string source_file;    ///< absolute path of the scene file ("" when built in code)
  SimulationSpec simulation;
  DomainSpec domain;
  FluidSpec fluid;
  std::vector<RigidBodySpec> rigid_bodies;
  std::vector<ClothSpec> cloth;
  std::vector<SoftBodySpec> soft_bodies;
  ProbesSpec probes;
  OutputSpec output;
  HapticsSpec haptics;
};

}  // namespace sph
