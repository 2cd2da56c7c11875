// Model: everything derived from a SceneSpec that stays fixed during a run (MuJoCo's mjModel),
// and compile(), which derives it: smoothing length, particle masses, speed of sound, the
// neighbour grid, boundary particles with their volumes, nozzles, particle budget, stage mask.
// The initial particles come out of compile() as HostParticles, which the Simulation uploads.
#pragma once

#include "core/cloth.h"
#include "core/rigid.h"
#include "core/scene_spec.h"
#include "core/stages.h"
#include "kernels/shared/sim_params.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace sph {

/// Particles on the host, structure of arrays (n entries each). Positions and velocities are
/// float4 (x, y, z, unused) to match the device buffers.
struct HostParticles {
  std::vector<Eigen::Vector4f> pos;     ///< (unit: m)
  std::vector<Eigen::Vector4f> vel;     ///< (unit: m/s)
  std::vector<Eigen::Vector4f> colour;  ///< linear RGB + unused
  std::vector<uint32_t> phase;          ///< phase index
  std::vector<uint32_t> id;             ///< creation order
  std::size_t size() const { return pos.size(); }
  void push(const Eigen::Vector3f& x, const Eigen::Vector3f& v, const Eigen::Vector3f& c, uint32_t ph, uint32_t i);
};

/// A nozzle, compiled: the lattice points of one emitted layer, in world space at the nozzle.
struct Emitter {
  InflowSpec spec;
  uint32_t phase = 0;
  Eigen::Vector3d direction;                  ///< unit vector
  std::vector<Eigen::Vector3d> layer;         ///< positions of one layer (unit: m)
};

struct Model {
  SceneSpec spec;
  double dx = 0;          ///< particle spacing (unit: m)
  /// Scenes with fluid: dynamic bodies touch the closed walls across a film this thick, one spacing dx
  /// (the thinnest water film SPH resolves; core/model.cpp says why); 0 without fluid (unit: m).
  double wall_film = 0;
  double support = 0;     ///< kernel support radius H = support_ratio * dx (unit: m)
  double h = 0;           ///< smoothing length H / 2 (unit: m)
  double skin = 0;        ///< Verlet-list skin: lists hold neighbours within H + skin (unit: m)
  double c0 = 0;          ///< speed of sound (unit: m/s)
  double frame_dt = 0;    ///< 1 / frame_rate (unit: s)
  int num_frames = 0;     ///< frames to simulate: round(duration * frame_rate)
  double max_viscosity = 0;  ///< largest phase kinematic viscosity (unit: m^2/s)
  /// DFSPH's viscous step bound for the artificial viscosity, dt <= C h / (alpha c0): C = 1 / (h
  /// lambda) with lambda the largest pair-relaxation rate of Monaghan's term per alpha c0 on a resting
  /// lattice (core/model.cpp, artificialViscosityStepFactor; 0.685 for the cubic spline at H = 2 dx).
  /// 0 when the artificial term is off (unit: 1).
  double artificial_step_factor = 0;

  SimParams params{};     ///< device constants (n_fluid, dt and gravity are set per step)
  StageMask stages;
  /// Boundary particles whose viscous velocity is the no-slip ghost velocity (fluid.boundary_velocity,
  /// kernels/viscosity.cl boundary_ghost_velocity): 0 none (the wall's own velocity), 1 all, 2 moving
  /// bodies' particles only.
  uint32_t ghost_velocity_mode = 0;
  /// Moving rigid bodies and fluid.body_ambient_pressure subtract (auto, the default since session 33: with WCSPH),
  /// with WCSPH or DFSPH's extrapolated walls: each body's pressure force leaves out the ambient pressure's share of its
  /// sampled surface's closure error (kernels/rigid.cl, rigid_reduce; docs/forces.md, sessions 32-33).
  bool body_ambient_subtract = false;
  /// The running mean of each body particle's wall pressure that the reference pressure reads: long
  /// beside WCSPH's acoustic noise at a body (a spacing's crossing at c0, ~1 ms; 250-550 Pa standard
  /// deviation over a ball's particles), short beside a body's flow (a 6 cm ball sinking from rest
  /// changes its pressures over ~50 ms) (unit: s).
  static constexpr double kBodyAmbientTime = 0.01;
  std::string program_options;  ///< OpenCL build options (kernel choice, viscosity model)

  /// Static boundary particles (closed walls and static rigid bodies), sorted by grid cell: xyz (unit: m), w = V_b / V0 (Akinci 2012 volume).
  std::vector<Eigen::Vector4f> boundary;
  std::vector<uint32_t> boundary_cell_start;  ///< num_cells + 1 entries
  /// Per `boundary` particle: on a static rigid body's sampled surface (one irregular layer) its
  /// outward unit normal, w = 1 (DFSPH's contact and non-penetration there: kernels/dfsph.cl,
  /// dfsph_wall_contact_accel and dfsph_surface_impulse); zero on the closed walls' lattice.
  std::vector<Eigen::Vector4f> boundary_normal;

  /// Rigid bodies (scene order). Static bodies' particles are also part of `boundary` above.
  std::vector<rigid::RigidBody> bodies;

  /// Cloths (core/cloth.h): nodes, spring table, colours.
  cloth::ClothModel cloth;

  std::vector<Emitter> emitters;
  std::size_t capacity = 0;   ///< particle budget (device buffers are this large)
  /// Time steps one frame may take under CFL subdivision (ResourceLimits; compile() refuses scenes
  /// that need more at the start; a run that needs more later should stop with a reason). (unit: 1)
  double max_steps_per_frame = 1.0e5;

  std::vector<std::string> notes;  ///< derived choices worth telling the user (c0, budget, ...)
  std::vector<std::string> warnings;  ///< scene keys given but not used (validate and run print them)
};

struct Compiled {
  Model model;
  HostParticles initial;
};

/// Bounds on what a scene may ask for, checked by compile() before anything is allocated.
struct ResourceLimits {
  double max_bytes = 0;                ///< memory a scene may need; 0 = the machine's physical memory (unit: bytes)
  double max_steps_per_frame = 1.0e5;  ///< time steps one frame may take under CFL subdivision (unit: 1)
};

/// What compile() expects a scene to need, from its keys alone (no allocation).
struct ResourceEstimate {
  double fluid_particles = 0;     ///< particle budget: blocks + nozzle emission, or max_particles (unit: 1)
  double boundary_particles = 0;  ///< behind the closed walls (unit: 1)
  double body_particles = 0;      ///< on the rigid bodies' surfaces (unit: 1)
  double grid_cells = 0;          ///< neighbour grid (unit: 1)
  double cloth_nodes = 0;         ///< nodes of all cloths (unit: 1)
  double bytes = 0;               ///< host + device memory (unit: bytes)
  double steps_per_frame = 0;     ///< at the start, from the CFL and viscous limits (unit: 1)
  std::string str() const;        ///< "about 7.4 GB (1.2e8 fluid particles, ...)"
};

/// The machine's physical memory (unit: bytes); 0 when unknown.
double machineMemoryBytes();

/// "7.4 GB" (decimal units).
std::string humanBytes(double bytes);

/// Validates what the schema cannot (sizes against the domain, budget, resources against
/// `limits`) and derives the Model. Throws InputError (with the scene location) on bad input.
Compiled compile(const SceneSpec& spec, const ResourceLimits& limits = {});

/// The estimate compile() checks against its limits; `worst` (optional) is set to the location
/// of the key that asks for the most memory.
ResourceEstimate estimateResources(const SceneSpec& spec, SourceLoc* worst = nullptr);

/// Akinci et al. 2012 eq. 4: V_b = 1 / sum_k W(x_b - x_k) over the boundary particles k (self included).
std::vector<float> akinciVolumes(const std::vector<Eigen::Vector3f>& points, float support, int kernel);

/// The factor on Akinci volumes of a body's sampled surface layer that makes a flat face of it
/// weigh, in the density sum of a fluid particle resting dx/2 outside it, what the domain's wall
/// (a complete lattice of volume dx^3 per particle) weighs there. (unit: 1)
double bodyVolumeScale(double dx, double support, int kernel);

/// Gravity at time t with the scene's ramp (0 -> full over gravity_ramp seconds, smooth).
Eigen::Vector3d gravityAt(const SimulationSpec& sim, double t);
/// The smooth ramp of gravityAt: 0 at t = 0, 1 from t = duration on, zero slope at both ends (unit: 1).
double smoothRamp(double t, double duration);

}  // namespace sph
