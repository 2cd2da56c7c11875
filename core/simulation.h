// Simulation: the particle state on the device and the time step that advances it.
// Simulation::step() is the whole algorithm, top to bottom; advanceFrame() chooses the number of
// steps per frame (CFL control) and runs the per-frame diagnostics.
#pragma once

#include "core/cl_context.h"
#include "core/cloth.h"
#include "core/mesh_distance.h"
#include "core/contact.h"
#include "core/external_force.h"
#include "core/dfsph.h"
#include "core/errors.h"
#include "core/isosurface.h"
#include "core/model.h"
#include "core/particle_frame.h"
#include "core/prefix_sum.h"
#include "core/probes.h"
#include "core/stages.h"

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace sph {

/// What set a DFSPH step (Simulation::dfsphStepLimit): the scene's largest step, the CFL limit of
/// the largest speed, a viscous limit (Morris et al. 1997 for the laminar model; the pair
/// relaxation of the artificial term, Model::artificial_step_factor), or the density solve's
/// iterations (fluid.dfsph.step_iterations), or the largest pressure (fluid.dfsph.pressure_cfl).
enum class StepLimiter : int { MaxTimeStep = 0, Cfl = 1, Viscous = 2, Iterations = 3, Pressure = 4 };
inline constexpr int kNumStepLimiters = 5;
/// "max_time_step", "cfl", "viscous", "iterations", "pressure" (run.json, the summary).
inline const char* stepLimiterName(StepLimiter l) {
  return l == StepLimiter::Cfl          ? "cfl"
         : l == StepLimiter::Viscous    ? "viscous"
         : l == StepLimiter::Iterations ? "iterations"
         : l == StepLimiter::Pressure   ? "pressure"
                                        : "max_time_step";
}

/// Wall time spent in each stage (host-side, each stage waits for its kernels), and counts.
struct Profile {
  std::array<double, kNumStages> seconds{};  ///< (unit: s)
  uint64_t steps = 0;                        ///< time steps taken
  uint64_t particle_steps = 0;               ///< sum over steps of the fluid particle count
  uint64_t subdivided_frames = 0;            ///< frames where CFL control added steps
  uint64_t cfl_warned_frames = 0;            ///< frames run with dt above the CFL limit (policy warn)
  uint64_t grid_builds = 0;                  ///< neighbour-grid and list rebuilds (Verlet lists)
  /// Part of seconds[rigid_coupling]: the per-body reduction (kernel rigid_reduce and the read of
  /// the sums), timed from a queue finish after rigid_fluid_forces to the end of the read (unit: s).
  double rigid_reduce_seconds = 0;
  // DFSPH (solver dfsph): iterations of both solves, steps that stopped at the most iterations, and
  // the largest average errors reached at the end of a step.
  uint64_t density_iterations = 0;     ///< density-solve iterations, all steps
  uint64_t divergence_iterations = 0;  ///< divergence-solve iterations, all steps
  uint64_t density_corrections = 0;    ///< density-solve coarse-grid corrections (two-level solve), all steps
  uint64_t corrections_reused = 0;     ///< of the corrections, those with a reused coarse operator (fluid.dfsph.coarse_reuse)
  uint64_t corrections_stopped = 0;    ///< solves whose coarse-grid corrections stopped: one did not lower the error
  uint64_t divergence_corrections = 0; ///< divergence-solve coarse-grid corrections, all steps
  uint64_t unconverged_steps = 0;      ///< steps whose density solve stopped above its bound
  double max_density_error = 0;        ///< largest average density error at the end of a step (unit: 1)
  double max_divergence_error = 0;     ///< largest average divergence error at the end of a step (unit: 1)
  // DFSPH's implicit viscosity (fluid.dfsph.viscosity_solve: implicit): conjugate-gradient iterations,
  // steps that stopped at the most iterations, the largest residual reached (sqrt(r.z / r0.z0)).
  uint64_t viscosity_iterations = 0;          ///< all steps (unit: 1)
  uint64_t viscosity_unconverged_steps = 0;   ///< steps above fluid.dfsph.viscosity_tolerance (unit: 1)
  double max_viscosity_residual = 0;          ///< (unit: 1)
  /// DFSPH steps by what set their length (index: StepLimiter) (unit: 1).
  std::array<uint64_t, kNumStepLimiters> dfsph_step_limiters{};
  /// DFSPH: the largest dt sqrt(max p / rho) / dx of a step with its own pressures, and the steps where
  /// it passed 1, the pressure scale past which a resting column bounced (docs/dfsph.md, session 15;
  /// fluid.dfsph.pressure_cfl bounds it) (unit: 1).
  double max_pressure_step_ratio = 0;
  uint64_t steps_over_pressure_scale = 0;
  // The settle before t = 0 (simulation.settle_time; Simulation::settle): its steps and wall time,
  // kept apart from the run's (the fields above count from t = 0).
  uint64_t settle_steps = 0;     ///< time steps of the settle (unit: 1)
  double settle_seconds = 0;     ///< wall time of the settle (unit: s)
  double settle_max_speed = 0;   ///< the fluid's largest speed in the settle's last step, before it was zeroed (unit: m/s)
  double total() const;
};

/// One step's fluid force on one moving body, for the per-step force log (output.step_forces).
struct StepForce {
  double time = 0;                                    ///< start of the step: the pose the force acts at (unit: s)
  std::size_t body = 0;                               ///< index into Model::bodies
  Eigen::Vector3d v = Eigen::Vector3d::Zero();        ///< velocity of the centre of mass (unit: m/s)
  Eigen::Vector3d w = Eigen::Vector3d::Zero();        ///< angular velocity, world (unit: rad/s)
  Eigen::Vector3d force = Eigen::Vector3d::Zero();    ///< fluid force (unit: N)
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();   ///< fluid torque about the centre of mass (unit: N m)
};

/// What the diagnostics found at the end of one frame.
struct FrameReport {
  int frame = 0;                 ///< index of the frame just completed (0-based)
  double time = 0;               ///< simulated time at its end (unit: s)
  int steps = 0;                 ///< time steps taken in this frame
  double dt = 0;                 ///< step used (unit: s)
  double dt_limit = 0;           ///< CFL / viscous limit at frame start (unit: s)
  StepLimiter dt_limiter = StepLimiter::Cfl;  ///< DFSPH: what set dt_limit (WCSPH: Cfl)
  uint32_t nonfinite = 0;        ///< particles with NaN/inf position, velocity or density
  uint32_t outside = 0;          ///< particles that left the domain box through an open wall (not an error)
  uint32_t cfl_violations = 0;   ///< particles that moved more than h in one step
  uint32_t wall_crossings = 0;   ///< particles put back after crossing a closed wall (a warning, never fatal)
  float max_speed = 0;           ///< (unit: m/s)
  int64_t first_bad_id = -1;     ///< id of a particle with a problem, -1 if none
  // DFSPH (solver dfsph): this frame's solver iterations and the largest average errors reached
  int density_iterations = 0;    ///< density-solve iterations, all steps of the frame
  int divergence_iterations = 0; ///< divergence-solve iterations, all steps of the frame
  int unconverged_steps = 0;     ///< steps whose density solve stopped at max_iterations above the bound (a warning)
  double density_error = 0;      ///< largest average density error at a step's end (unit: 1)
  double divergence_error = 0;   ///< largest average divergence error at a step's end (unit: 1)
  /// largest free body's error at the end of a density solve that stopped at max_iterations (strong
  /// body coupling: fluid.dfsph.body_error) (unit: m/s^2)
  double unconverged_body_error = 0;
  std::size_t particles = 0;     ///< fluid particles at frame end
  std::vector<std::string> messages;  ///< one-off notices (particle budget reached, ...)
  bool clean() const { return nonfinite == 0 && cfl_violations == 0 && wall_crossings == 0; }
};

class Simulation {
 public:
  /// Uploads the model's boundary and the initial particles; builds the kernels for the model.
  Simulation(const Model& model, const HostParticles& initial, ClContext& cl);
  // Members point at each other (the prefix sum and the mesher use kernels_): neither copy nor move.
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  /// Removes a stage (from `--disable`); returns false if the stage is essential (grid, density, integrate).
  bool disable(Stage s);
  const StageMask& stages() const { return stages_; }
  /// Fluid neighbour lists as 32-bit indices (wide) rather than 16-bit offsets j - i (narrow,
  /// kernels/shared/neighbours.h). The lists switch to wide by themselves when some offset does
  /// not fit; useWideLists() makes them wide from the next list build on (tests: bitwise the same
  /// results either way).
  bool wideLists() const { return params_.wide_lists != 0; }
  void useWideLists() { params_.wide_lists = 1; lists_valid_ = false; }

  /// One time step of length dt (unit: s).
  void step(double dt);
  /// The scene's settle before t = 0 (simulation.settle_time > 0; else nothing): the fluid steps from
  /// t = -settle_time to 0 under gravity (ramped in over the first quarter) with every velocity damped
  /// by exp(-dt / settle_damping) after each step, while bodies, cloth, inflows, colour mixing,
  /// probes and haptics stay still; then the fluid's velocities are set to 0 and the state is
  /// prepared as at construction, at t = 0. Runs once: advanceFrame() runs it if it has not run
  /// (so every caller gets the scene's settled start), after any disable() (the stage mask holds).
  /// Throws NumericalError if the settle leaves a non-finite particle.
  void settle();
  bool settled() const { return settled_; }
  /// Steps through one output frame and runs the diagnostics. Under policy 'abort' a problem
  /// throws NumericalError naming frame, time, stage and particle.
  FrameReport advanceFrame();
  /// A flag the frame's step loops read before every step (null: none): when it is nonzero,
  /// advanceFrame throws Interrupted, leaving the frame unfinished (a stop asked for by a signal
  /// takes effect within a step, not at the end of a frame that may take minutes).
  void setInterrupt(const std::atomic<int>* flag) { interrupt_ = flag; }

  double time() const { return time_; }
  int frame() const { return frame_; }
  std::size_t numFluid() const { return n_; }
  const Model& model() const { return model_; }
  const Profile& profile() const { return profile_; }
  const std::map<std::string, uint64_t>& dispatchCounts() const { return kernels_.dispatchCounts(); }
  /// Per-kernel wall time (`--profile-kernels`): every dispatch waits for its kernel; no result changes.
  void profileKernels(bool on) { kernels_.setTiming(on); }
  const std::map<std::string, double>& kernelSeconds() const { return kernels_.kernelSeconds(); }
  const std::map<std::string, double>& kernelCpuSeconds() const { return kernels_.kernelCpuSeconds(); }

  /// Rigid bodies: the compiled bodies (model().bodies) and their current states, same order.
  const std::vector<rigid::BodyState>& bodies() const { return bodies_; }
  /// External forces on bodies (a haptic grab), called once per step while Stage::Haptics is on;
  /// null = none. The source must outlive the simulation's steps.
  void setExternalForces(ExternalForceSource* source) { external_ = source; }
  /// Per-step force log: when on, every step appends each moving body's fluid force (StepForce);
  /// takeStepForces() hands over what was recorded since the last call.
  void recordStepForces(bool on) { record_forces_ = on; }
  std::vector<StepForce> takeStepForces() { return std::exchange(step_forces_, {}); }

  /// Cloths (null without a cloth section): node positions, energies, broken springs.
  cloth::ClothSim* cloth() { return cloth_.get(); }
  /// Probes (scene section `probes`): with recordProbeSamples(true) every sample is kept until
  /// takeProbeSamples() hands them over; latestProbeSample() is the newest (null before the first).
  void recordProbeSamples(bool on) { record_probes_ = on; }
  std::vector<ProbeSample> takeProbeSamples() { return std::exchange(probe_samples_, {}); }
  const ProbeSample* latestProbeSample() const { return latest_probe_ ? &*latest_probe_ : nullptr; }

  /// Copies the fluid particles to the host.
  ParticleFrame readFrame();
  /// Diagnostics of the body coupling (reads only): each moving body's boundary particle, in body
  /// order (Model::bodies, then its particles), as the last step left it: world position and volume
  /// ratio V_b / V0 (w) in `pos`; the fluid's force on it (xyz, unit: N) and its wall pressure
  /// (w, unit: Pa; Adami et al. 2012 eq. 27) in `force`.
  void readBodyParticles(std::vector<Eigen::Vector4f>& pos, std::vector<Eigen::Vector4f>& force);
  /// FNV-1a hash of the particles' positions, velocities, colours, phases and ids and the rigid
  /// bodies' poses, velocities and angular momenta (bitwise determinism checks). Reads only.
  uint64_t stateHash();

  /// Isosurface of the current state: one mesh per phase (index = phase), from the device
  /// (core/isosurface.h). The mesher and its buffers are created on the first call, so a run
  /// without isosurfaces enqueues none of its kernels.
  std::vector<TriMesh> surfaceMeshes(const IsoSettings& settings);
  /// The surface grid of the last surfaceMeshes() call (null before the first).
  const SurfaceGridShape* lastSurfaceGrid() const { return mesher_ ? &mesher_->lastGrid() : nullptr; }
  /// The surface field of `phase` from the last surfaceMeshes() call (empty before the first).
  DenseGrid surfaceField(uint32_t phase) { return mesher_ ? mesher_->readField(phase) : DenseGrid{}; }

  /// Device memory held by this simulation's buffers (unit: bytes).
  std::size_t deviceBytes() const {
    return device_bytes_ + prefix_sum_.bytes() + (mesher_ ? mesher_->bytes() : 0) + (cloth_ ? cloth_->bytes() : 0) +
           (dfsph_ ? dfsph_->bytes() : 0);
  }

 private:
  void emitInflow(double dt);
  void buildGrid();
  void computeDensity();
  void sampleProbes();
  void pressureForces();
  void divergenceSolve();
  void densitySolve();
  DfsphFields dfsphFields();
  int dfsphWallMode() const;
  double dfsphStepLimit(StepLimiter* limiter = nullptr) const;
  double wcsphStepLimit(double max_speed) const;
  Eigen::Vector3d gravityNow() const;
  void viscosityForces();
  void ghostVelocities();
  /// The boundary velocities the viscous terms read: the no-slip ghost velocities when the model
  /// asks for them (Model::ghost_velocity_mode) and this step computed them (ghostVelocities runs
  /// with the viscosity stage), else the wall's own (bvel_). Its w (the body flag) also sets the
  /// contact range (pair_loops.h), so the fluid and the body side must read the same buffer.
  const cl::Buffer& viscousBoundaryVelocities() const {
    return model_.ghost_velocity_mode && on(Stage::Viscosity) ? bghost_ : bvel_;
  }
  void diffuseColour();
  void integrate();
  void integrateBodies(double dt);
  void applyExternalForces(double dt);
  void placeBodyParticles();
  void sortBoundary();
  void gatherBodyForces();
  void addedMassReaction(double dt);
  bool heldBody(std::size_t b) const;
  void stepCloth(double dt);
  void placeClothParticles();
  void gatherClothForces();
  bool strongCloth() const;
  void clothResponse(double dt);
  bool strongBodies() const;
  void bodyResponse(double dt);
  void clothAddedMass();
  /// The balls the cloth meets (rigid spheres, at their pose and velocity now) and their body indices.
  std::vector<cloth::SphereCollider> clothSpheres(std::vector<std::size_t>* which) const;
  FrameReport runDiagnostics();
  void prepareInitialState();
  void abortOnNumericalFailure(const FrameReport& rep, const char* nonfinite_stage) const;
  cl::Buffer makeBuffer(std::size_t bytes);

  // A timed block: waits for the queue at its end so the profile is per stage.
  struct StageTimer {
    Simulation& sim;
    Stage stage;
    std::chrono::steady_clock::time_point t0;
    StageTimer(Simulation& s, Stage st) : sim(s), stage(st), t0(std::chrono::steady_clock::now()) {}
    ~StageTimer();
  };
  bool on(Stage s) const { return stages_.on(s); }

  Model model_;
  ClContext& cl_;
  KernelSet kernels_;
  StageMask stages_;
  SimParams params_;
  Profile profile_;
  double time_ = 0.0;
  int frame_ = 0;
  bool settled_ = false;   // settle() has run (or the scene has none)
  bool settling_ = false;  // inside settle(): time_ runs from -settle_time to 0
  std::size_t n_ = 0;         // active fluid particles
  uint32_t next_id_ = 0;      // id of the next emitted particle
  float last_max_speed_ = 0;  // from the previous diagnostics (unit: m/s)
  std::vector<double> emitter_travel_;  // distance travelled since the last emitted layer (unit: m)
  std::vector<std::string> pending_messages_;
  bool budget_reported_ = false;
  std::size_t device_bytes_ = 0;
  std::vector<rigid::BodyState> bodies_;  // one per model_.bodies
  std::unique_ptr<rigid::ContactSolver> contacts_;  // with moving bodies: contact between bodies and walls
  // The closed walls as the bodies touch them: the domain moved in by Model::wall_film (in water, a
  // film of one spacing; core/model.cpp says why). Set once, read by every step's integrateBodies.
  DomainSpec body_walls_;
  // Moving (dynamic, kinematic) bodies as boundary particles after the static ones (kernels/rigid.cl).
  std::vector<std::size_t> moving_;       // indices into model_.bodies
  std::vector<double> moving_reach_;      // farthest particle from the centre of mass (unit: m)
  uint32_t n_static_ = 0, n_moving_ = 0;  // boundary particles: static, moving
  // Cloth nodes coupled with the fluid: boundary particles after the moving bodies' (kernels/cloth.cl).
  uint32_t n_cloth_ = 0;
  cl::Buffer node_share_;  // DFSPH's added mass of wet cloth nodes: per node J_k / s_k (clothAddedMass)
  cl::Buffer cloth_volume_, cloth_force_;  // per node: V_b / V0 (Akinci 2012), fluid force (unit: N)
  cl::Buffer bdata_;          // DFSPH strong body coupling: per moving body DFSPH_BODY_STRIDE float4 (kernels/shared/body_response.h)
  cl::Buffer node_response_;  // DFSPH strong coupling: per node M^-1 of this step (3 float4, unit: 1/kg)
  cl::Buffer node_dv_;        // DFSPH strong coupling: per node the step's velocity change without the fluid (unit: m/s)
  double body_speed_ = 0.0;               // fastest moving body particle this step (unit: m/s)
  ExternalForceSource* external_ = nullptr; // haptics: the grabbed body's coupling (not owned)
  std::vector<BodyWrench> wrenches_;      // its output, one per body
  bool record_forces_ = false;            // per-step force log on
  std::vector<StepForce> step_forces_;    // recorded since the last takeStepForces()
  cl::Buffer bsrc_, blocal_, bbody_, bslot_, bpose_, bforce_, bgeo_, bpmean_, brange_, bsum_, bcell_, brank_, bsorted_, bcount_;
  cl::Buffer bnormal_, bnormal_src_;  // static bodies' sampled layers: outward normals, w = 1 (sorted; source order)
  uint32_t n_sampled_ = 0;            // static boundary particles on a body's sampled layer
  // DFSPH's fictitious body mass (addedMassReaction): this step's M per body (unit: kg; 0 = none),
  // and on the device s_k per moving particle, S per moving body (unit: kg/m^3), -J / S per
  // moving body (unit: m^4/s).
  std::vector<double> added_mass_;
  const std::atomic<int>* interrupt_ = nullptr;  // setInterrupt: a stop asked for; checked before every step
  void checkInterrupt() const {
    if (interrupt_ && interrupt_->load()) throw Interrupted("interrupted at t = " + std::to_string(time_) + " s");
  }
  cl::Buffer bweight_, bweight_sum_, bshare_;

  // Per-particle fields, double-buffered for the reorder (cur_ is the live half).
  int cur_ = 0;
  std::array<cl::Buffer, 2> pos_, vel_, colour_, phase_, id_;
  cl::Buffer acc_, density_, pressure_, pterm_, cell_, rank_, sorted_;
  // Neighbour lists (fluid and boundary), written by the density pass, read by the force stages.
  cl::Buffer nbr_, nbr_count_, bnbr_, bnbr_count_, overflow_;
  // Set by the list build when some fluid list's offsets do not fit in 16 bits (narrow lists,
  // kernels/shared/neighbours.h): the lists are then built wide from there on (params_.wide_lists).
  cl::Buffer narrow_fail_;
  // This step's neighbours within H (written by the density pass), read by the force stages.
  cl::Buffer snbr_, snbr_count_, sbnbr_, sbnbr_count_;
  void allocateNeighbourLists(uint32_t slots);
  // Grid tables and scratch.
  cl::Buffer cell_count_, cell_start_, bpos_, bcell_start_, crossings_, diag_, max_speed_;
  cl::Buffer max_pressure_;  // DFSPH: the step's largest p_i / rho_i, float bits (dfsph_finish; unit: m^2/s^2)
  // Boundary particles' velocities, wall pressures (Adami 2012) and last-seen stamps, in bpos order.
  cl::Buffer bvel_, bpressure_, bmark_;
  cl::Buffer bghost_;  ///< no-slip ghost velocities (n_bnd x 4; kernels/viscosity.cl), with ghost_velocity_mode
  uint32_t stamp_ = 0;
  // Verlet lists: rebuilt when particles were added or some particle may have moved skin / 2.
  bool lists_valid_ = false;
  bool grid_built_ = false;  // the fluid is in cell order with cell_start_ (isosurface gathers through it)
  double travel_since_build_ = 0.0;  // sum over steps of max speed * dt (unit: m)
  double last_step_travel_ = 0.0;    // the last step's max speed * dt (unit: m)
  bool step_lists_ = false;          // DFSPH: the lists were built at H into the step lists (buildGrid)
  bool factors_done_ = false;        // DFSPH: this step's factors came with the density (computeDensity)
  PrefixSum prefix_sum_;
  std::unique_ptr<SurfaceMesher> mesher_;  // isosurface stage, created on first use
  // Bodies other than spheres and cutters that the cloth nodes collide with (host side, once per
  // step after the cloth solve): body index and its closed surface (body frame).
  std::vector<std::pair<std::size_t, std::unique_ptr<ClosedSurface>>> cloth_obstacles_;
  void collideClothWithBodies();
  std::vector<std::size_t> cutters_;          // bodies with cutter: true (indices into bodies_), scene order
  std::unique_ptr<cloth::ClothSim> cloth_;  // cloth stage (core/cloth.h), only with a cloth section
  std::unique_ptr<ProbeSampler> probes_;   // probes stage (scenes with a probes section)
  bool record_probes_ = false;
  std::vector<ProbeSample> probe_samples_; // taken since the last takeProbeSamples()
  std::optional<ProbeSample> latest_probe_;
  // DFSPH (solver dfsph): the solver, the step's largest speed, this frame's solver statistics.
  std::unique_ptr<DfsphSolver> dfsph_;
  double step_max_speed_ = 0.0;  // fluid and bodies, from the last integrate (unit: m/s)
  // DFSPH's blown-up-flow guard (advanceFrame): consecutive steps faster than 2 c0, and how many stop the
  // run (or one faster than 10 c0).
  int fast_steps_ = 0;
  static constexpr int kFastSteps = 3;
  double step_max_pressure_ = 0.0;  // DFSPH: the last step's largest p_i / rho_i (unit: m^2/s^2)
  double iteration_step_limit_ = INFINITY;  // DFSPH: the step bound of fluid.dfsph.step_iterations (unit: s)
  FrameReport dfsph_frame_;      // iteration and error fields only
  uint32_t diag_groups_ = 0;
};

}  // namespace sph
