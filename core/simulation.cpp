#include "core/simulation.h"

#include "core/errors.h"
#include "kernels/shared/body_response.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

namespace sph {

// Work-group size for the per-particle kernels.
static constexpr std::size_t kLocal = 64;

double Profile::total() const {
  double s = 0;
  for (double v : seconds) s += v;
  return s;
}

Simulation::StageTimer::~StageTimer() {
  sim.cl_.queue().finish();
  sim.profile_.seconds[static_cast<std::size_t>(stage)] +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

cl::Buffer Simulation::makeBuffer(std::size_t bytes) {
  bytes = std::max<std::size_t>(bytes, 16);
  device_bytes_ += bytes;
  return clCall("allocating a device buffer", [&] { return cl::Buffer(cl_.context(), CL_MEM_READ_WRITE, bytes); });
}

Simulation::Simulation(const Model& model, const HostParticles& initial, ClContext& cl)
    : model_(model), cl_(cl), kernels_(cl, model.program_options), stages_(model.stages), params_(model.params) {
  const std::size_t cap = model_.capacity;
  const std::size_t cells = model_.params.num_cells;
  SPH_ASSERT(initial.size() <= cap, "initial particles exceed the capacity");

  // Per-particle buffers at full capacity (the particle budget), so inflows never reallocate.
  for (int b = 0; b < 2; ++b) {
    pos_[b] = makeBuffer(cap * 16);
    vel_[b] = makeBuffer(cap * 16);
    colour_[b] = makeBuffer(cap * 16);
    phase_[b] = makeBuffer(cap * 4);
    id_[b] = makeBuffer(cap * 4);
  }
  acc_ = makeBuffer(cap * 16);
  density_ = makeBuffer(cap * 4);
  pressure_ = makeBuffer(cap * 4);
  pterm_ = makeBuffer(cap * 4);
  cell_ = makeBuffer(cap * 4);
  rank_ = makeBuffer(cap * 4);
  sorted_ = makeBuffer(cap * 4);
  nbr_count_ = makeBuffer(cap * 4);
  bnbr_count_ = makeBuffer(cap * 4);
  snbr_count_ = makeBuffer(cap * 4);
  sbnbr_count_ = makeBuffer(cap * 4);
  overflow_ = makeBuffer(4);
  narrow_fail_ = makeBuffer(4);
  // Neighbour-list slots: 1.5x the particles within the list radius in the bulk at rest, plus 8.
  const double ratio = (model_.support + model_.skin) / model_.dx;
  allocateNeighbourLists(static_cast<uint32_t>((1.5 * 4.18879 * ratio * ratio * ratio + 8.0 + 7.0) / 8.0) * 8u);

  // Grid tables; the scan works in chunks of ~1k cells.
  cell_count_ = makeBuffer(cells * 4);
  cell_start_ = makeBuffer((cells + 1) * 4);
  prefix_sum_ = PrefixSum(cl_, kernels_);
  // Moving bodies: their particles follow the static boundary particles (kernels/rigid.cl).
  n_static_ = static_cast<uint32_t>(model_.boundary.size());
  std::vector<Eigen::Vector4f> local;
  std::vector<uint32_t> body_of, range;
  for (std::size_t b = 0; b < model_.bodies.size(); ++b) {
    const rigid::RigidBody& body = model_.bodies[b];
    if (body.kind == rigid::BodyKind::Static || !stages_.on(Stage::RigidCoupling)) continue;
    range.push_back(static_cast<uint32_t>(local.size()));
    range.push_back(static_cast<uint32_t>(body.particles.size()));
    double reach = 0.0;
    for (std::size_t i = 0; i < body.particles.size(); ++i) {
      const Eigen::Vector3f& x = body.particles[i];
      local.emplace_back(x.x(), x.y(), x.z(), body.volumes[i]);
      body_of.push_back(static_cast<uint32_t>(moving_.size()));
      reach = std::max(reach, static_cast<double>(x.norm()));
    }
    moving_.push_back(b);
    moving_reach_.push_back(reach);
  }
  n_moving_ = static_cast<uint32_t>(local.size());
  // Cloth nodes (with fluid): boundary particles after the moving bodies', their volumes those of
  // a sampled surface like a body's (Akinci 2012 eq. 4, scaled as bodyVolumeScale says).
  std::vector<float> cloth_volume;
  if (stages_.on(Stage::ClothCoupling)) {
    const cloth::ClothModel& cm = model_.cloth;
    n_cloth_ = static_cast<uint32_t>(cm.nodes());
    const double scale = bodyVolumeScale(model_.dx, model_.support, model_.params.kernel_type) / (model_.dx * model_.dx * model_.dx);
    for (std::size_t c = 0; c < cm.first_node.size(); ++c) {
      std::vector<Eigen::Vector3f> pts;
      for (uint32_t i = cm.first_node[c]; i < cm.first_node[c] + cm.num_nodes[c]; ++i) pts.push_back(cm.x0[i].head<3>());
      for (float v : akinciVolumes(pts, static_cast<float>(model_.support), model_.params.kernel_type))
        cloth_volume.push_back(static_cast<float>(v * scale));
    }
    cloth_volume_ = makeBuffer(n_cloth_ * 4);
    cloth_force_ = makeBuffer(n_cloth_ * 16);
  }
  const std::size_t n_bnd = n_static_ + n_moving_ + n_cloth_;
  bpos_ = makeBuffer(n_bnd * 16);
  bvel_ = makeBuffer(n_bnd * 16);       // zero for static particles
  // Static bodies' sampled layers: their outward normals (Model::boundary_normal), for DFSPH's contact
  // and non-penetration there (kernels/dfsph.cl); a placeholder without any.
  n_sampled_ = 0;
  for (const Eigen::Vector4f& nrm : model_.boundary_normal) n_sampled_ += nrm.w() > 0.0f ? 1u : 0u;
  bnormal_ = makeBuffer(n_sampled_ > 0 ? n_bnd * 16 : 16);
  bpressure_ = makeBuffer(n_bnd * 4);   // Adami 2012 wall pressure (pressure.cl)
  bmark_ = makeBuffer(n_bnd * 4);       // stamp of the last step a fluid particle saw it
  if (model_.ghost_velocity_mode) bghost_ = makeBuffer(n_bnd * 16);  // no-slip ghost velocities (viscosity.cl)
  bcell_start_ = makeBuffer((cells + 1) * 4);
  crossings_ = makeBuffer(4);
  max_speed_ = makeBuffer(4);
  max_pressure_ = makeBuffer(4);
  diag_groups_ = 64;
  diag_ = makeBuffer(diag_groups_ * 32);

  if (n_moving_ + n_cloth_ > 0) {
    bsrc_ = makeBuffer(n_bnd * 16);
    if (n_sampled_ > 0) bnormal_src_ = makeBuffer(n_static_ * 16);  // the static particles' normals, source order
    blocal_ = makeBuffer(n_moving_ * 16);
    bbody_ = makeBuffer(n_moving_ * 4);
    bslot_ = makeBuffer(n_bnd * 4);
    bpose_ = makeBuffer(moving_.size() * 64);
    bforce_ = makeBuffer(n_moving_ * 16);
    bgeo_ = makeBuffer(n_moving_ * 16);  // per body particle: pressure force per pascal, running mean pressure
    bpmean_ = makeBuffer(n_moving_ * 4);  // running means of the body particles' wall pressure (fluid.body_ambient_pressure)
    clCall("clearing the body particles' mean pressures", [&] { return cl_.queue().enqueueFillBuffer(bpmean_, 0.0f, 0, std::size_t(n_moving_) * 4); });
    brange_ = makeBuffer(range.size() * 4);
    bsum_ = makeBuffer(moving_.size() * 32);
    bcell_ = makeBuffer(n_bnd * 4);
    brank_ = makeBuffer(n_bnd * 4);
    bsorted_ = makeBuffer(n_bnd * 4);
    bcount_ = makeBuffer(cells * 4);
  }

  // Upload the static boundary and the initial particles.
  auto& q = cl_.queue();
  clCall("uploading the initial state", [&] {
    const cl_float4 zero4{};  // (a plain float[4] would decay to a pointer: an 8-byte pattern)
    if (n_bnd > 0) {
      q.enqueueFillBuffer(bvel_, zero4, 0, n_bnd * 16);
      q.enqueueFillBuffer(bmark_, uint32_t(0), 0, n_bnd * 4);
    }
    if (!model_.boundary.empty()) {
      q.enqueueWriteBuffer(bpos_, CL_TRUE, 0, model_.boundary.size() * 16, model_.boundary.data());
      if (n_sampled_ > 0) {
        q.enqueueFillBuffer(bnormal_, cl_float4{}, 0, n_bnd * 16);
        q.enqueueWriteBuffer(bnormal_, CL_TRUE, 0, model_.boundary.size() * 16, model_.boundary_normal.data());
        if (n_moving_ + n_cloth_ > 0)
          q.enqueueWriteBuffer(bnormal_src_, CL_TRUE, 0, model_.boundary.size() * 16, model_.boundary_normal.data());
      }
    }
    q.enqueueWriteBuffer(bcell_start_, CL_TRUE, 0, (cells + 1) * 4, model_.boundary_cell_start.data());
    if (n_moving_ + n_cloth_ > 0) {
      // Until the first sort the moving particles sit unsorted after the static ones, outside
      // every cell of bcell_start (invisible); their slots are their own indices.
      std::vector<uint32_t> identity(n_bnd);
      for (uint32_t k = 0; k < n_bnd; ++k) identity[k] = k;
      q.enqueueWriteBuffer(bslot_, CL_TRUE, 0, n_bnd * 4, identity.data());
      if (n_static_ > 0) q.enqueueCopyBuffer(bpos_, bsrc_, 0, 0, n_static_ * 16);
      if (n_moving_ > 0) {
        q.enqueueWriteBuffer(blocal_, CL_TRUE, 0, n_moving_ * 16, local.data());
        q.enqueueWriteBuffer(bbody_, CL_TRUE, 0, n_moving_ * 4, body_of.data());
        q.enqueueWriteBuffer(brange_, CL_TRUE, 0, range.size() * 4, range.data());
      }
      if (n_cloth_ > 0) {
        q.enqueueWriteBuffer(cloth_volume_, CL_TRUE, 0, n_cloth_ * 4, cloth_volume.data());
        q.enqueueFillBuffer(cloth_force_, zero4, 0, n_cloth_ * 16);
      }
      q.finish();
    }
    const uint32_t zero = 0;
    q.enqueueWriteBuffer(crossings_, CL_TRUE, 0, 4, &zero);
    q.enqueueWriteBuffer(overflow_, CL_TRUE, 0, 4, &zero);
    q.enqueueWriteBuffer(narrow_fail_, CL_TRUE, 0, 4, &zero);
    q.enqueueWriteBuffer(max_speed_, CL_TRUE, 0, 4, &zero);
    q.enqueueWriteBuffer(max_pressure_, CL_TRUE, 0, 4, &zero);
    n_ = initial.size();
    if (n_ > 0) {
      q.enqueueWriteBuffer(pos_[0], CL_TRUE, 0, n_ * 16, initial.pos.data());
      q.enqueueWriteBuffer(vel_[0], CL_TRUE, 0, n_ * 16, initial.vel.data());
      q.enqueueWriteBuffer(colour_[0], CL_TRUE, 0, n_ * 16, initial.colour.data());
      q.enqueueWriteBuffer(phase_[0], CL_TRUE, 0, n_ * 4, initial.phase.data());
      q.enqueueWriteBuffer(id_[0], CL_TRUE, 0, n_ * 4, initial.id.data());
    }
    return 0;
  });
  next_id_ = static_cast<uint32_t>(n_);
  for (const rigid::RigidBody& body : model_.bodies) bodies_.push_back(rigid::initialState(body));
  if (on(Stage::RigidDynamics)) contacts_ = std::make_unique<rigid::ContactSolver>(model_.bodies, model_.dx);
  body_walls_ = model_.spec.domain;
  body_walls_.min.array() += model_.wall_film;
  body_walls_.max.array() -= model_.wall_film;
  // DFSPH: the solver and its buffers exist only with solver dfsph (a wcsph scene enqueues none of its kernels).
  if (model_.spec.fluid.solver == FluidSolver::Dfsph && cap > 0) {
    bool one_mass = true;  // every phase's particle mass is the first's (bitwise)
    for (std::size_t k = 1; k < model_.spec.fluid.phases.size() && k < SPH_MAX_PHASES; ++k)
      one_mass = one_mass && model_.params.phase_mass[k] == model_.params.phase_mass[0];
    dfsph_ = std::make_unique<DfsphSolver>(cl_, kernels_, cap, n_static_ + n_moving_ + n_cloth_, model_.spec.fluid.dfsph,
                                           model_.dx, model_.support, one_mass,
                                           model_.spec.domain.max - model_.spec.domain.min);
  }
  emitter_travel_.assign(model_.emitters.size(), model_.dx);  // the first layer leaves at the start time
  // Cloth nodes (stepped by stage cloth; with it disabled they hang still, still boundary for the fluid).
  if (model_.cloth.nodes() > 0) {
    cloth_ = std::make_unique<cloth::ClothSim>(model_.cloth, cl_, kernels_);
    // Cutters (rigid bodies with cutter: true) cut the cloths with their closed surfaces.
    std::vector<const TriMesh*> blades;
    for (std::size_t b = 0; b < model_.bodies.size(); ++b)
      if (model_.bodies[b].spec.cutter) {
        blades.push_back(&model_.bodies[b].mesh);
        cutters_.push_back(b);
      }
    cloth_->setCutters(blades);
    cloth_->setAddedMass(strongCloth() && model_.spec.fluid.dfsph.cloth_added_mass > 0.0);
    // Other shapes than spheres (boxes, cylinders, capsules, meshes) are obstacles through their
    // closed surfaces (core/mesh_distance.h).
    for (std::size_t b = 0; b < model_.bodies.size(); ++b) {
      const rigid::RigidBody& body = model_.bodies[b];
      if (body.spec.shape != BodyShape::Sphere && !body.spec.cutter)
        cloth_obstacles_.emplace_back(b, std::make_unique<ClosedSurface>(body.mesh));
    }
  }
  if (on(Stage::Probes)) probes_ = std::make_unique<ProbeSampler>(model_, cl_);
  prepareInitialState();
}

// The initial state as every later frame is seen: particles in cell order with valid neighbour
// lists, moving bodies' particles placed and sorted, density and pressure computed. Done here,
// always, so that frame 0 carries real fields and nothing an output does later (the isosurface
// needs a grid) can change when or how the first grid is built.
void Simulation::prepareInitialState() {
  params_.n_fluid = static_cast<sph_uint>(n_);
  if (n_ == 0) return;  // an inflow-only scene: the first emission builds the grid
  if (on(Stage::RigidCoupling)) placeBodyParticles();
  if (on(Stage::ClothCoupling)) placeClothParticles();
  if (on(Stage::RigidCoupling) || on(Stage::ClothCoupling)) sortBoundary();
  buildGrid();
  computeDensity();
}

void Simulation::allocateNeighbourLists(uint32_t slots) {
  const std::size_t bytes = model_.capacity * slots * 4;
  if (params_.max_neighbours > 0) device_bytes_ -= 4 * std::max<std::size_t>(model_.capacity * params_.max_neighbours * 4, 16);
  nbr_ = makeBuffer(bytes);
  bnbr_ = makeBuffer(bytes);
  snbr_ = makeBuffer(bytes);
  sbnbr_ = makeBuffer(bytes);
  params_.max_neighbours = slots;
}

bool Simulation::disable(Stage s) {
  if (s == Stage::Grid || s == Stage::Density || s == Stage::Integrate) return false;
  stages_.set(s, false);
  return true;
}

// ---------------------------------------------------------------------------------------------
// One time step. The whole algorithm, in order; each stage is timed into the profile.
// ---------------------------------------------------------------------------------------------
void Simulation::step(double dt) {
  // Per-step constants: step length, gravity (with the scene's ramp).
  params_.dt = static_cast<float>(dt);
  const Eigen::Vector3d g = gravityNow();
  for (int a = 0; a < 3; ++a) params_.gravity[a] = static_cast<float>(g[a]);

  if (on(Stage::Inflow)) emitInflow(dt);  // new particles enter at the nozzles
  params_.n_fluid = static_cast<sph_uint>(n_);
  // A grabbed body's coupling spring, from the bodies' state at the step's start (they move after the
  // fluid): before the solves, so that DFSPH's strong body coupling moves a body inside them under the
  // external force it is then integrated with, not the last step's (session 25; the wrench is the same
  // as when it was computed after the solves: it reads only the time and the bodies' poses and velocities).
  if (on(Stage::Haptics) && external_) applyExternalForces(dt);
  if (n_ > 0) {
    if (on(Stage::RigidCoupling)) placeBodyParticles(); // moving bodies' particles at their pose
    if (on(Stage::ClothCoupling)) placeClothParticles(); // cloth nodes as boundary particles
    if (!lists_valid_ || travel_since_build_ > (step_lists_ ? 0.0 : 0.5 * model_.skin)) {
      if (on(Stage::RigidCoupling) || on(Stage::ClothCoupling)) sortBoundary();  // moved particles change cells
      buildGrid();                                     // sort by cell, reorder, Verlet lists
    }
    computeDensity();                                  // number density, rho, p (S&P 2008, Akinci 2012)
    if (on(Stage::Probes) && probes_->due(time_)) sampleProbes();  // gauges read the state at the step's start
    if (strongCloth()) clothResponse(dt);              // DFSPH: how each cloth node answers a force this step
    if (strongBodies()) bodyResponse(dt);              // DFSPH: how each body answers a force this step
    if (on(Stage::DivergenceSolve)) divergenceSolve(); // DFSPH: factors, divergence-free velocities (B&K 2017 Alg. 2)
    if (on(Stage::Viscosity) && model_.ghost_velocity_mode)
      ghostVelocities();                               // no-slip wall velocities 2 v_w - v~ (Adami 2012 eq. 22-23)
    pressureForces();                                  // wall pressure (Adami 2012), -grad p / rho + g (+ viscosity, fused); dfsph: g
    if (on(Stage::Viscosity) && !on(Stage::Pressure))
      viscosityForces();                               // Monaghan or Morris, on its own; dfsph: explicit or implicit (CG)
    if (on(Stage::ColourDiffusion)) diffuseColour();   // colour mixing
    if (on(Stage::DensitySolve)) densitySolve();       // DFSPH: v* = v + dt a, constant density (B&K 2017 Alg. 3)
    if (on(Stage::RigidCoupling)) gatherBodyForces();  // fluid -> bodies: 6 numbers per body to the host
    if (on(Stage::ClothCoupling)) gatherClothForces(); // fluid -> cloth: one force per node, on the device
  }
  if (n_ > 0) {
    if (on(Stage::RigidCoupling) && on(Stage::RigidDynamics))
      addedMassReaction(dt);                           // DFSPH: bodies' fictitious mass, its reaction to the fluid
    integrate();                                       // semi-implicit Euler, closed walls
  }
  if (on(Stage::RigidDynamics)) integrateBodies(dt);   // rigid bodies: momenta, poses (host)
  if (on(Stage::Cloth)) stepCloth(dt);                 // cloth springs: XPBD or explicit, tearing
  time_ += dt;
  ++profile_.steps;
  profile_.particle_steps += n_;
}

double Simulation::dfsphStepLimit(StepLimiter* limiter) const {
  // CFL with the largest speed of the last step, plus what gravity adds over a longest step
  // (B&K 2017 section 4.3), and the viscous limits: Morris et al. 1997 with a laminar model, the
  // artificial term's pair relaxation dt <= C h / (alpha c0) with the artificial model
  // (Model::artificial_step_factor: a longer step reverses the approach of neighbouring layers
  // within one step, and the layers bounce with period 2).
  const DfsphSpec& d = model_.spec.fluid.dfsph;
  const double g = model_.spec.simulation.gravity.norm();
  const double v = step_max_speed_ + g * d.max_time_step;
  double limit = d.max_time_step;
  StepLimiter by = StepLimiter::MaxTimeStep;
  auto bound = [&](double l, StepLimiter who) {
    if (l < limit) limit = l, by = who;
  };
  if (v > 0.0) bound(d.cfl * model_.dx / v, StepLimiter::Cfl);
  if (on(Stage::Viscosity) && model_.spec.fluid.viscosity_model == ViscosityModel::Laminar && model_.max_viscosity > 0 &&
      d.viscosity_solve == ViscositySolve::Explicit)  // the implicit solve has no viscous bound
    bound(0.125 * model_.h * model_.h / model_.max_viscosity, StepLimiter::Viscous);
  if (on(Stage::Viscosity) && model_.spec.fluid.viscosity_model == ViscosityModel::Artificial &&
      model_.artificial_step_factor > 0.0 && model_.spec.fluid.artificial_viscosity > 0.0 && model_.c0 > 0.0)
    bound(model_.artificial_step_factor * model_.h / (model_.spec.fluid.artificial_viscosity * model_.c0),
          StepLimiter::Viscous);
  if (d.step_iterations > 0) bound(iteration_step_limit_, StepLimiter::Iterations);
  // The pressure's own step bound (fluid.dfsph.pressure_cfl; docs/dfsph.md, session 15): a pressure p
  // pushes particle pairs apart with a stiffness that grows with p / rho (the pressure term of SPH's
  // particle-scale dispersion: Swegle, Hicks & Attaway 1995), and the density solve holds only the
  // compressive modes, so the others are integrated explicitly: a resting column of depth H bounced
  // from dt sqrt(g H) / dx ~ 0.9 (H, dx and g varied, measured) and rested below ~0.8.
  if (d.pressure_cfl > 0.0 && step_max_pressure_ > 0.0)
    bound(d.pressure_cfl * model_.dx / std::sqrt(step_max_pressure_), StepLimiter::Pressure);
  if (limiter) *limiter = by;
  return limit;
}

Eigen::Vector3d Simulation::gravityNow() const {
  const SimulationSpec& sim = model_.spec.simulation;
  if (!settling_) return gravityAt(sim, time_);
  // The settle (t from -settle_time to 0): gravity ramps in smoothly over its first quarter (the ramp
  // of gravityAt, zero slope at both ends), full after, so the fluid comes to rest under the load it
  // carries from t = 0 on. The lattice gives way only under the full load: a ramp over the first half
  // left a 1 s settle of the resting tank 1.2 kPa short of rest, over a quarter it is calm (docs/dfsph.md,
  // session 22).
  const double ramp = 0.25 * sim.settle_time, t = time_ + sim.settle_time;
  return t >= ramp ? sim.gravity : Eigen::Vector3d(smoothRamp(t, ramp) * sim.gravity);
}

// WCSPH's step limit at the largest speed max_speed (unit: s): the CFL and viscous limits (Monaghan
// 1992: dt <= cfl h / (c0 + |v|max); Morris et al. 1997: dt <= 0.125 h^2 / nu). A scene without
// fluid (rigid bodies alone) has no CFL limit.
double Simulation::wcsphStepLimit(double max_speed) const {
  double limit = model_.capacity == 0 ? INFINITY : model_.spec.simulation.cfl * model_.h / (model_.c0 + max_speed);
  if (on(Stage::Viscosity) && model_.spec.fluid.viscosity_model == ViscosityModel::Laminar && model_.max_viscosity > 0)
    limit = std::min(limit, 0.125 * model_.h * model_.h / model_.max_viscosity);
  return limit;
}

// The settle before t = 0 (simulation.settle_time; docs/dfsph.md, session 22). A fluid block starts
// on a cubic lattice, which is not stable under the water's own weight: in a resting tank its bottom
// layers give way ~0.2-0.6 s after the load is on (rows sliding past each other; the column 0.3 mm
// lower), and the solver answers the rearrangement with a bounce of kPa (DFSPH) or a ringing (WCSPH)
// long after t = 0 (docs/dfsph.md, sessions 12 and 21). Here the fluid goes through that before t = 0,
// with its velocities damped, so a scene at rest starts at rest, in the packing its solver holds, at
// its hydrostatic pressure. Only the fluid moves: bodies stay at their initial pose with zero velocity,
// cloth and soft bodies as placed (their nodes are still walls to the fluid); inflows, colour mixing,
// probes, haptics and the per-step force log wait for t = 0.
void Simulation::settle() {
  if (settled_) return;
  settled_ = true;
  const SimulationSpec& sim = model_.spec.simulation;
  if (!(sim.settle_time > 0.0) || n_ == 0) return;
  const auto t0 = std::chrono::steady_clock::now();
  const StageMask saved_stages = stages_;
  for (Stage s : {Stage::Inflow, Stage::Probes, Stage::ColourDiffusion, Stage::Haptics, Stage::RigidDynamics, Stage::Cloth})
    stages_.set(s, false);
  const bool saved_record = record_forces_;
  record_forces_ = false;
  // Bodies held still (rigid_dynamics off: their poses do not change), their particles carrying no
  // velocity into the fluid; their own velocities come back at t = 0.
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> body_velocities;
  for (rigid::BodyState& b : bodies_) body_velocities.emplace_back(b.v, b.w), b.v.setZero(), b.w.setZero();
  const Profile saved_profile = profile_;
  settling_ = true;
  time_ = -sim.settle_time;
  // WCSPH: the scene's own steps (frame / substeps, within the CFL limit of the last step's speed);
  // DFSPH: its adaptive steps. As many steps as the frames it spans may take, at most.
  const double max_steps = static_cast<double>(model_.max_steps_per_frame) * std::ceil(sim.settle_time / model_.frame_dt);
  uint64_t taken = 0;
  while (-time_ > 1e-12 * sim.settle_time) {
    const double limit = dfsph_ ? dfsphStepLimit()
                                : std::min(model_.frame_dt / sim.substeps, wcsphStepLimit(step_max_speed_));
    const double k = std::ceil(-time_ / limit - 1e-9);
    const double dt = k <= 1.0 ? -time_ : -time_ / k;
    if (!(static_cast<double>(taken) + k <= max_steps)) {  // a blown-up speed: stop with the reason, never loop
      std::ostringstream s;
      s << "numerical failure in the settle before t = 0 (simulation.settle_time = " << sim.settle_time << " s) at t = "
        << time_ << " s: it would take more than " << max_steps << " steps (step " << dt
        << " s, stage: time-step control); the flow has blown up";
      throw NumericalError(s.str());
    }
    checkInterrupt();
    step(dt);
    ++taken;
    const float factor = static_cast<float>(std::exp(-dt / sim.settle_damping));
    kernels_.call("scale_velocity", n_, kLocal, params_, factor, vel_[cur_]);
  }
  const double last_speed = step_max_speed_;
  // At rest at t = 0: velocities zeroed, the fields computed for the settled positions.
  kernels_.call("scale_velocity", n_, kLocal, params_, 0.0f, vel_[cur_]);
  settling_ = false;
  time_ = 0.0;
  stages_ = saved_stages;
  record_forces_ = saved_record;
  for (std::size_t b = 0; b < bodies_.size(); ++b) bodies_[b].v = body_velocities[b].first, bodies_[b].w = body_velocities[b].second;
  const uint64_t steps = profile_.steps - saved_profile.steps;
  profile_ = saved_profile;  // the run's counters start at t = 0
  profile_.settle_steps = steps;
  profile_.settle_max_speed = last_speed;
  step_max_speed_ = 0.0;
  step_max_pressure_ = 0.0;
  iteration_step_limit_ = INFINITY;
  dfsph_frame_ = FrameReport{};
  prepareInitialState();
  // A settle that blew up is reported as such, not as frame 0's failure.
  if (on(Stage::Diagnostics)) {
    const FrameReport rep = runDiagnostics();
    if (rep.nonfinite > 0) {
      std::ostringstream s;
      s << "numerical failure in the settle before t = 0 (simulation.settle_time = " << sim.settle_time << " s, "
        << steps << " steps): " << rep.nonfinite << " particle(s) with NaN/inf";
      throw NumericalError(s.str());
    }
  }
  profile_.settle_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

FrameReport Simulation::advanceFrame() {
  const SimulationSpec& sim = model_.spec.simulation;
  settle();  // the scene's settle before t = 0, if it has not run
  if (dfsph_) {
    // DFSPH: adaptive steps, each within the CFL limit of the last step's speed; the frame ends
    // exactly (the steps left in a frame are evened out, so no sliver of a step remains).
    const double frame_end = (frame_ + 1) * model_.frame_dt;
    StepLimiter limiter0 = StepLimiter::Cfl;
    const double limit0 = dfsphStepLimit(&limiter0);
    dfsph_frame_ = FrameReport{};
    int steps = 0;
    double smallest = INFINITY;
    while (frame_end - time_ > 1e-12 * model_.frame_dt) {
      const double left = frame_end - time_;
      StepLimiter limiter = StepLimiter::Cfl;
      const double k = std::ceil(left / dfsphStepLimit(&limiter) - 1e-9);
      const double dt = k <= 1.0 ? left : left / k;
      if (!(steps < model_.max_steps_per_frame)) {  // a blown-up speed: stop with the reason, never loop
        std::ostringstream s;
        s << "numerical failure at frame " << frame_ << ", t = " << time_ << " s: the frame took more than "
          << model_.max_steps_per_frame << " steps (step " << dt << " s, stage: time-step control); the flow has blown up";
        throw NumericalError(s.str());
      }
      // A speed over twice the scene's speed of sound (which it declares as ~10x its fastest flow), step
      // after step, is a blown-up flow whose CFL steps collapse: a 32k-particle DFSPH scene crawled for
      // 48 min in one frame before this (session 16); stop with the reason instead. One particle kicked
      // that fast and slowed again by the next step's solve is not (scenes/haptic_stir_live.yaml, c0 = 3
      // m/s: single steps with one particle at 6-18 m/s, at 0.045, 0.45, 0.61 s..., the run calm to its
      // end; session 17), so the speed must persist for kFastSteps steps (the sealed sheet of
      // scenes/tests/dfsph_cloth_sandwich.yaml blowing up with the staggered coupling: 3 and 12 steps in
      // a row), or pass 10 c0 (100x the declared fastest flow), which no kicked particle reached.
      fast_steps_ = model_.c0 > 0.0 && step_max_speed_ > 2.0 * model_.c0 ? fast_steps_ + 1 : 0;
      if (fast_steps_ >= kFastSteps || (model_.c0 > 0.0 && step_max_speed_ > 10.0 * model_.c0)) {
        std::ostringstream s;
        s << "numerical failure at frame " << frame_ << ", t = " << time_ << " s: a particle moves at "
          << step_max_speed_ << " m/s, over twice the speed of sound c0 = " << model_.c0 << " m/s ("
          << fast_steps_ << " step(s) in a row; stage: time-step control; step " << dt << " s); the flow has blown up";
        throw NumericalError(s.str());
      }
      checkInterrupt();
      step(dt);
      // The step against its own pressure scale (fluid.dfsph.pressure_cfl; reported, whether bounded or not)
      if (step_max_pressure_ > 0.0) {
        const double ratio = dt * std::sqrt(step_max_pressure_) / model_.dx;
        profile_.max_pressure_step_ratio = std::max(profile_.max_pressure_step_ratio, ratio);
        if (ratio > 1.0) ++profile_.steps_over_pressure_scale;
      }
      // The frame's last step may be a remainder shorter than the limit: still counted by it.
      ++profile_.dfsph_step_limiters[static_cast<std::size_t>(limiter)];
      smallest = std::min(smallest, dt);
      ++steps;
    }
    time_ = frame_end;
    FrameReport rep;
    if (on(Stage::Diagnostics)) rep = runDiagnostics();
    rep.frame = frame_;
    rep.time = time_;
    rep.steps = steps;
    rep.dt = steps > 0 ? smallest : 0.0;
    rep.dt_limit = limit0;
    rep.dt_limiter = limiter0;
    rep.particles = n_;
    rep.density_iterations = dfsph_frame_.density_iterations;
    rep.divergence_iterations = dfsph_frame_.divergence_iterations;
    rep.unconverged_steps = dfsph_frame_.unconverged_steps;
    rep.density_error = dfsph_frame_.density_error;
    rep.divergence_error = dfsph_frame_.divergence_error;
    rep.unconverged_body_error = dfsph_frame_.unconverged_body_error;
    if (rep.unconverged_steps > 0) {
      // What kept them going: the fluid's average density error, or (strong body coupling) a free
      // body's error, or both.
      const DfsphSpec& d = model_.spec.fluid.dfsph;
      const bool fluid = rep.density_error > d.density_error, body = rep.unconverged_body_error > d.body_error;
      std::ostringstream s;
      s << rep.unconverged_steps << " step(s) stopped at fluid.dfsph.max_iterations = " << d.max_iterations << " with ";
      if (fluid || !body) s << "the average density error above " << d.density_error << " (largest " << rep.density_error << ")";
      if (fluid && body) s << " and ";
      if (body)
        s << "a free body's error above fluid.dfsph.body_error = " << d.body_error << " m/s^2 (largest "
          << rep.unconverged_body_error << " m/s^2; the density error " << rep.density_error << ")";
      pending_messages_.push_back(s.str());
    }
    rep.messages = std::move(pending_messages_);
    pending_messages_.clear();
    ++frame_;
    abortOnNumericalFailure(rep, "density_solve");
    return rep;
  }
  // Time-step control: the scene's substeps, checked against the CFL and viscous limits.
  const double limit = wcsphStepLimit(last_max_speed_);
  int steps = sim.substeps;
  double dt = model_.frame_dt / steps;
  if (dt > limit * (1.0 + 1e-9)) {
    if (sim.time_step_control == TimeStepControl::Subdivide) {
      // A speed that blew up mid-run would make the frame take unbounded steps: stop with the reason.
      const double needed = std::ceil(model_.frame_dt / limit);
      if (!(needed <= model_.max_steps_per_frame)) {
        std::ostringstream s;
        s << "numerical failure at frame " << frame_ << ", t = " << time_ << " s: the CFL limit " << limit
          << " s (largest speed " << last_max_speed_ << " m/s) would need " << needed << " steps for this frame, more than "
          << model_.max_steps_per_frame << " (stage: time-step control); the flow has blown up";
        throw NumericalError(s.str());
      }
      steps = static_cast<int>(needed);
      dt = model_.frame_dt / steps;
      ++profile_.subdivided_frames;
    } else {
      ++profile_.cfl_warned_frames;
    }
  }
  for (int k = 0; k < steps; ++k) {
    checkInterrupt();
    step(dt);
  }
  time_ = (frame_ + 1) * model_.frame_dt;  // no drift from summing steps

  FrameReport rep;
  if (on(Stage::Diagnostics)) rep = runDiagnostics();
  rep.frame = frame_;
  rep.time = time_;
  rep.steps = steps;
  rep.dt = dt;
  rep.dt_limit = limit;
  rep.particles = n_;
  rep.messages = std::move(pending_messages_);
  pending_messages_.clear();
  ++frame_;

  abortOnNumericalFailure(rep, "integrate");
  return rep;
}

// Policy: abort on NaN/inf or a CFL violation, naming frame, time, stage and particle. Wall
// crossings were already repaired (the particle is back inside): they are reported, not fatal.
void Simulation::abortOnNumericalFailure(const FrameReport& rep, const char* nonfinite_stage) const {
  if (model_.spec.simulation.numerical_errors != NumericalPolicy::Abort || (rep.nonfinite == 0 && rep.cfl_violations == 0))
    return;
  std::ostringstream s;
  s << "numerical failure at frame " << rep.frame << ", t = " << rep.time << " s: ";
  if (rep.nonfinite) s << rep.nonfinite << " particle(s) with NaN/inf (stage: " << nonfinite_stage << "); ";
  if (rep.cfl_violations)
    s << rep.cfl_violations << " particle(s) moved more than h in one step (CFL, stage: integrate; dt = " << rep.dt
      << " s); ";
  if (rep.first_bad_id >= 0) s << "first particle id " << rep.first_bad_id;
  throw NumericalError(s.str());
}

// --- Stages ------------------------------------------------------------------------------------

void Simulation::emitInflow(double dt) {
  StageTimer timer(*this, Stage::Inflow);
  HostParticles fresh;
  for (std::size_t e = 0; e < model_.emitters.size(); ++e) {
    const Emitter& em = model_.emitters[e];
    if (time_ < em.spec.start || time_ >= em.spec.stop) continue;
    // A layer leaves each time the column has advanced one particle spacing.
    emitter_travel_[e] += em.spec.speed * dt;
    while (emitter_travel_[e] >= model_.dx) {
      emitter_travel_[e] -= model_.dx;
      if (n_ + fresh.size() + em.layer.size() > model_.capacity) {
        if (!budget_reported_) {
          std::ostringstream s;
          s << "particle budget of " << model_.capacity << " reached at t = " << time_
            << " s: inflows stop emitting (raise fluid.max_particles to emit more)";
          pending_messages_.push_back(s.str());
          budget_reported_ = true;
        }
        continue;
      }
      const PhaseSpec& ph = model_.spec.fluid.phases[em.phase];
      const Eigen::Vector3d v = em.spec.speed * em.direction;
      for (const Eigen::Vector3d& x0 : em.layer) {
        const Eigen::Vector3d x = x0 + emitter_travel_[e] * em.direction;  // already moved this far
        fresh.push(x.cast<float>(), v.cast<float>(), ph.colour.cast<float>(), em.phase, next_id_++);
      }
    }
  }
  if (fresh.size() == 0) return;
  const std::size_t k = fresh.size();
  clCall("uploading emitted particles", [&] {
    auto& q = cl_.queue();
    q.enqueueWriteBuffer(pos_[cur_], CL_FALSE, n_ * 16, k * 16, fresh.pos.data());
    q.enqueueWriteBuffer(vel_[cur_], CL_FALSE, n_ * 16, k * 16, fresh.vel.data());
    q.enqueueWriteBuffer(colour_[cur_], CL_FALSE, n_ * 16, k * 16, fresh.colour.data());
    q.enqueueWriteBuffer(phase_[cur_], CL_FALSE, n_ * 4, k * 4, fresh.phase.data());
    q.enqueueWriteBuffer(id_[cur_], CL_FALSE, n_ * 4, k * 4, fresh.id.data());
    q.finish();  // `fresh` goes out of scope
    return 0;
  });
  n_ += k;
  lists_valid_ = false;  // new particles need neighbours
}

void Simulation::buildGrid() {
  StageTimer timer(*this, Stage::Grid);
  auto& q = cl_.queue();
  const uint32_t zero = 0;
  clCall("clearing the cell counts",
         [&] { return q.enqueueFillBuffer(cell_count_, zero, 0, std::size_t(params_.num_cells) * 4); });
  // cell of each particle and its rank in the cell -> prefix sum -> sorted index -> fixed order
  kernels_.call("grid_assign", n_, kLocal, params_, pos_[cur_], cell_, rank_, cell_count_);
  prefix_sum_.run(cell_count_, cell_start_, params_.num_cells);
  kernels_.call("grid_scatter", n_, kLocal, params_, cell_, rank_, cell_start_, sorted_);
  kernels_.call("grid_order_cells", n_, kLocal, params_, cell_, cell_start_, sorted_);
  // gather every field into cell order, then swap halves
  const int nxt = 1 - cur_;
  kernels_.call("grid_reorder", n_, kLocal, params_, sorted_, pos_[cur_], vel_[cur_], colour_[cur_], phase_[cur_], id_[cur_], pos_[nxt], vel_[nxt], colour_[nxt], phase_[nxt], id_[nxt]);
  cur_ = nxt;
  if (dfsph_) dfsph_->reorder(n_, sorted_);  // the accumulated pressures follow their particles
  // Neighbour lists within H + skin. DFSPH: when the last step moved some particle a whole skin
  // (twice what the lists allow: core/model.cpp skinRatio), lists built now would expire after this
  // step anyway (a flowing scene: each step at CFL 0.4 moves the fastest particle ~0.4 dx, ~8
  // skins), so they are built at H straight into this step's lists, which the density pass then
  // only sums over (performance: shorter lists, one list written instead of two); they are
  // rebuilt at the next step that moves anything. A slower flow keeps the Verlet lists.
  step_lists_ = dfsph_ && last_step_travel_ > model_.skin;
  const float radius = step_lists_ ? params_.support : params_.cell_size;  // (unit: m)
  const auto buildLists = [&] {
    kernels_.call("build_neighbour_lists", n_, kLocal, params_, pos_[cur_], cell_start_, bpos_, bcell_start_,
                  step_lists_ ? snbr_ : nbr_, step_lists_ ? snbr_count_ : nbr_count_, step_lists_ ? sbnbr_ : bnbr_,
                  step_lists_ ? sbnbr_count_ : bnbr_count_, overflow_, radius, narrow_fail_);
  };
  buildLists();
  // Narrow fluid lists (16-bit offsets j - i, kernels/shared/neighbours.h; performance: the passes
  // stream half the bytes) hold while every particle's candidates lie within 32,767 places of it;
  // with at most 32,768 particles they always do. Otherwise the build says whether some did not
  // (one read per build): then the lists become wide (32-bit indices) for the rest of the run and
  // are built again, so this step already reads complete lists.
  if (!params_.wide_lists && n_ > 32768) {
    uint32_t fail = 0;
    clCall("reading the narrow-list check",
           [&] { return cl_.queue().enqueueReadBuffer(narrow_fail_, CL_TRUE, 0, 4, &fail); });
    if (fail) {
      params_.wide_lists = 1;
      pending_messages_.push_back("a particle's neighbours lie more than 32,767 places from it in cell order: "
                                  "neighbour lists switched to 32-bit indices");
      buildLists();
    }
  }
  lists_valid_ = true;
  grid_built_ = true;
  travel_since_build_ = 0.0;
  ++profile_.grid_builds;
}

void Simulation::computeDensity() {
  StageTimer timer(*this, Stage::Density);
  ++stamp_;  // marks the boundary particles within H of fluid this step (for boundary_pressure)
  // DFSPH with this step's lists: the factor pass sums the density too (kernels/dfsph.cl, dfsph_factor,
  // bitwise compute_density's values), one neighbour pass fewer per step (performance; docs/dfsph.md,
  // session 51). Not with cloth nodes inside the solves: clothResponse (after the density) gives the
  // factor pass their responses and changes the fluid's velocities (their added mass's reaction). The
  // bodies' responses (bodyResponse) are read only in the solves.
  factors_done_ = false;
  if (dfsph_ && step_lists_ && !strongCloth() &&
      (on(Stage::DivergenceSolve) || on(Stage::DensitySolve))) {
    dfsph_->factors(params_, dfsphFields(), on(Stage::DivergenceSolve), true);
    factors_done_ = true;
    return;
  }
  // the lists (this step's already when buildGrid built them at H: then only the sums)
  const cl::Buffer& nbr = step_lists_ ? snbr_ : nbr_;
  const cl::Buffer& nbr_count = step_lists_ ? snbr_count_ : nbr_count_;
  const cl::Buffer& bnbr = step_lists_ ? sbnbr_ : bnbr_;
  const cl::Buffer& bnbr_count = step_lists_ ? sbnbr_count_ : bnbr_count_;
  kernels_.call("compute_density", n_, kLocal, params_, pos_[cur_], phase_[cur_], bpos_, nbr, nbr_count, bnbr, bnbr_count, density_, pressure_, pterm_, snbr_, snbr_count_, sbnbr_, sbnbr_count_, stamp_, bmark_, step_lists_ ? 1 : 0);
}

void Simulation::sampleProbes() {
  StageTimer timer(*this, Stage::Probes);
  // Each sample point gathers fluid and boundary particles within H plus the drift since the grid
  // was built (capped, as for the isosurface: a NaN run must not hang here).
  const float reach = static_cast<float>(model_.support + std::min(travel_since_build_, 4.0 * model_.support));
  const uint32_t count = static_cast<uint32_t>(probes_->numPoints());
  // The pressure probed: WCSPH's equation of state of this step's density; DFSPH's the solver's
  // pressure of the last step (both solves', which moved the fluid to here; B&K 2017 eq. 12 and 15;
  // kernels/dfsph.cl dfsph_finish), not the equation of state the density pass also writes.
  const cl::Buffer& pressure = dfsph_ ? dfsph_->stepPressure(n_) : pressure_;
  kernels_.call("probe_sample", count, kLocal, params_, count, reach, probes_->pointBuffer(), pos_[cur_], vel_[cur_],
                phase_[cur_], density_, pressure, cell_start_, bpos_, bcell_start_, probes_->sumBuffer());
  std::vector<float> sums(8 * std::size_t(count));
  clCall("reading the probe samples",
         [&] { return cl_.queue().enqueueReadBuffer(probes_->sumBuffer(), CL_TRUE, 0, sums.size() * 4, sums.data()); });
  latest_probe_ = probes_->reduce(time_, sums);
  if (record_probes_) probe_samples_.push_back(*latest_probe_);
  probes_->taken(time_);
}

void Simulation::pressureForces() {
  StageTimer timer(*this, Stage::Pressure);
  if (!on(Stage::Pressure)) {  // gravity still acts
    kernels_.call("gravity_only", n_, kLocal, params_, acc_);
    return;
  }
  // Wall pressure extrapolated from the fluid (Adami et al. 2012), then the forces.
  const uint32_t n_bnd = n_static_ + n_moving_ + n_cloth_;
  if (n_bnd > 0)
    kernels_.call("boundary_pressure", n_bnd, kLocal, params_, n_bnd, stamp_, bpos_, bmark_, pos_[cur_], density_, pressure_, cell_start_, bpressure_);
  if (on(Stage::Viscosity)) {  // one neighbour loop for both (pressure.cl, pressure_viscosity_force)
    kernels_.call("pressure_viscosity_force", n_, kLocal, params_, pos_[cur_], vel_[cur_], phase_[cur_], density_, pterm_, snbr_, snbr_count_, bpos_, viscousBoundaryVelocities(), bpressure_, sbnbr_, sbnbr_count_, acc_);
    return;
  }
  kernels_.call("pressure_force", n_, kLocal, params_, pos_[cur_], phase_[cur_], density_, pterm_, snbr_, snbr_count_, bpos_, bvel_, bpressure_, sbnbr_, sbnbr_count_, acc_);
}

// --- DFSPH (core/dfsph.h, kernels/dfsph.cl) -----------------------------------------------------

// How the rigid coupling mirrors DFSPH's wall terms (rigid.cl, rigid_fluid_forces): 0 WCSPH (wall
// pressure and contact), 2 mirrored, 1 single, -1 extrapolated (wall pressure, no contact).
int Simulation::dfsphWallMode() const {
  if (!dfsph_) return 0;
  switch (model_.spec.fluid.dfsph.walls) {
    case DfsphWalls::Mirrored: return 2;
    case DfsphWalls::Single: return 1;
    case DfsphWalls::Extrapolated: return -1;
  }
  return 0;
}

DfsphFields Simulation::dfsphFields() {
  DfsphFields f;
  f.pos = &pos_[cur_];
  f.vel = &vel_[cur_];
  f.acc = &acc_;
  f.phase = &phase_[cur_];
  f.density = &density_;
  f.snbr = &snbr_;
  f.snbr_count = &snbr_count_;
  f.bpos = &bpos_;
  f.bvel = &bvel_;
  f.bnormal = &bnormal_;
  f.n_sampled = n_sampled_;
  f.sbnbr = &sbnbr_;
  f.sbnbr_count = &sbnbr_count_;
  f.pressure = &pressure_;
  f.pterm = &pterm_;
  f.n_boundary = static_cast<uint32_t>(n_static_ + n_moving_ + n_cloth_);
  f.stamp = stamp_;
  f.bmark = &bmark_;
  f.cell_start = &cell_start_;
  f.bpressure = &bpressure_;
  f.max_speed = step_max_speed_;
  f.max_pressure = &max_pressure_;
  // The cloth's free nodes move inside the solves (strong coupling, kernels/dfsph.cl).
  if (strongCloth()) {
    f.n_nodes = n_cloth_;
    f.node_offset = n_static_ + n_moving_;
    f.nodes = &cloth_->positions();
    f.response = &node_response_;
    f.bslot = &bslot_;
    f.row_start = &cloth_->rowStart();
    f.spring = &cloth_->springs();
    f.other = &cloth_->others();
    f.prm = &cloth_->springParams();
    f.broken = &cloth_->brokenSprings();
    f.node_dv = &node_dv_;
  }
  // The free dynamic bodies move inside the solves too (body_coupling: strong, kernels/dfsph.cl).
  if (strongBodies()) {
    f.n_bodies = static_cast<uint32_t>(moving_.size());
    f.n_moving = static_cast<uint32_t>(n_moving_);
    f.n_static = static_cast<uint32_t>(n_static_);
    f.bsrc = &bsrc_;
    f.bslot = &bslot_;
    f.body_of = &bbody_;
    f.body_range = &brange_;
    f.body_data = &bdata_;
    f.body_force = &bforce_;
  }
  return f;
}

void Simulation::divergenceSolve() {
  StageTimer timer(*this, Stage::DivergenceSolve);
  const DfsphFields f = dfsphFields();
  if (!factors_done_) dfsph_->factors(params_, f, true);  // else with the density (computeDensity)
  const DfsphSolveResult r = dfsph_->divergenceSolve(params_, f);
  dfsph_frame_.divergence_iterations += r.iterations;
  dfsph_frame_.divergence_error = std::max(dfsph_frame_.divergence_error, r.error);
  profile_.divergence_iterations += static_cast<uint64_t>(r.iterations);
  profile_.divergence_corrections += static_cast<uint64_t>(r.corrections);
  profile_.corrections_reused += static_cast<uint64_t>(r.reused);
  profile_.corrections_stopped += r.corrections_stopped ? 1u : 0u;
  profile_.max_divergence_error = std::max(profile_.max_divergence_error, r.error);
}

void Simulation::densitySolve() {
  StageTimer timer(*this, Stage::DensitySolve);
  const DfsphFields f = dfsphFields();
  if (!on(Stage::DivergenceSolve) && !factors_done_) dfsph_->factors(params_, f, false);  // else computed this step already
  const DfsphSolveResult r = dfsph_->densitySolve(params_, f);
  dfsph_->finish(params_, f);
  dfsph_frame_.density_iterations += r.iterations;
  dfsph_frame_.density_error = std::max(dfsph_frame_.density_error, r.error);
  if (!r.converged) {
    ++dfsph_frame_.unconverged_steps, ++profile_.unconverged_steps;
    dfsph_frame_.unconverged_body_error = std::max(dfsph_frame_.unconverged_body_error, r.body_error);
  }
  // fluid.dfsph.step_iterations: a solve that worked hard shortens the next steps, an easy one lets
  // them grow back (the CFL, viscous and largest-step bounds still apply).
  const DfsphSpec& d = model_.spec.fluid.dfsph;
  if (d.step_iterations > 0) {
    if (r.iterations > d.step_iterations)
      iteration_step_limit_ = 0.9 * std::min(iteration_step_limit_, static_cast<double>(params_.dt));
    else if (2 * r.iterations < d.step_iterations && iteration_step_limit_ < d.max_time_step)
      iteration_step_limit_ = 1.1 * iteration_step_limit_;
  }
  profile_.density_iterations += static_cast<uint64_t>(r.iterations);
  profile_.density_corrections += static_cast<uint64_t>(r.corrections);
  profile_.corrections_reused += static_cast<uint64_t>(r.reused);
  profile_.corrections_stopped += r.corrections_stopped ? 1u : 0u;
  profile_.max_density_error = std::max(profile_.max_density_error, r.error);
}

void Simulation::viscosityForces() {
  StageTimer timer(*this, Stage::Viscosity);
  if (dfsph_ && model_.spec.fluid.dfsph.viscosity_solve == ViscositySolve::Implicit) {
    // backward Euler by conjugate gradients (fluid.dfsph.viscosity_solve: implicit; kernels/viscosity.cl)
    const ViscositySolveResult r =
        dfsph_->viscositySolve(params_, dfsphFields(), viscousBoundaryVelocities(), model_.ghost_velocity_mode);
    profile_.viscosity_iterations += static_cast<uint64_t>(r.iterations);
    profile_.max_viscosity_residual = std::max(profile_.max_viscosity_residual, r.residual);
    if (!r.converged) ++profile_.viscosity_unconverged_steps;
    return;
  }
  kernels_.call("viscosity_force", n_, kLocal, params_, pos_[cur_], vel_[cur_], phase_[cur_], density_, snbr_, snbr_count_, bpos_, viscousBoundaryVelocities(), sbnbr_, sbnbr_count_, acc_);
}

void Simulation::ghostVelocities() {
  StageTimer timer(*this, Stage::Viscosity);
  // Every boundary particle the fluid saw this step: 2 v_w minus the fluid's Shepard-interpolated
  // velocity (kernels/viscosity.cl); the viscous terms between fluid and boundary read these.
  const uint32_t n_bnd = n_static_ + n_moving_ + n_cloth_;
  if (n_bnd > 0)
    kernels_.call("boundary_ghost_velocity", n_bnd, kLocal, params_, n_bnd, stamp_, model_.ghost_velocity_mode, bpos_, bvel_, bmark_, pos_[cur_], vel_[cur_], cell_start_, bghost_);
}

void Simulation::diffuseColour() {
  StageTimer timer(*this, Stage::ColourDiffusion);
  const int nxt = 1 - cur_;
  kernels_.call("colour_diffuse", n_, kLocal, params_, pos_[cur_], phase_[cur_], density_, colour_[cur_], snbr_, snbr_count_, colour_[nxt]);
  // The other fields are not double-buffered past this point: copy the new colours back.
  clCall("copying colours", [&] { return cl_.queue().enqueueCopyBuffer(colour_[nxt], colour_[cur_], 0, 0, n_ * 16); });
}

void Simulation::integrate() {
  StageTimer timer(*this, Stage::Integrate);
  kernels_.call("integrate", n_, kLocal, params_, pos_[cur_], vel_[cur_], acc_, crossings_, max_speed_);
  // The step's largest speed bounds every displacement: the lists stay valid while the sum of
  // max speed * dt since they were built is below skin / 2.
  uint32_t bits = 0, pbits = 0;
  const uint32_t zero = 0;
  clCall("reading the step's largest speed", [&] {
    cl_.queue().enqueueReadBuffer(max_speed_, CL_TRUE, 0, 4, &bits);
    cl_.queue().enqueueWriteBuffer(max_speed_, CL_TRUE, 0, 4, &zero);
    // DFSPH: the step's largest p_i / rho_i (dfsph_finish), for the pressure step bound
    if (dfsph_ && on(Stage::DensitySolve)) {
      cl_.queue().enqueueReadBuffer(max_pressure_, CL_TRUE, 0, 4, &pbits);
      cl_.queue().enqueueWriteBuffer(max_pressure_, CL_TRUE, 0, 4, &zero);
    }
    return 0;
  });
  float vmax, pmax;
  std::memcpy(&vmax, &bits, 4);
  std::memcpy(&pmax, &pbits, 4);
  step_max_pressure_ = std::isfinite(pmax) ? pmax : 0.0;
  // Moving boundary particles count too: fluid-body pairs close in at most twice the larger speed.
  const double fastest = std::max(static_cast<double>(vmax), body_speed_);
  step_max_speed_ = std::isfinite(fastest) ? fastest : 0.0;
  last_step_travel_ = std::isfinite(vmax) ? fastest * params_.dt : INFINITY;
  travel_since_build_ += last_step_travel_;
}

// --- Rigid coupling (kernels/rigid.cl) ----------------------------------------------------------

void Simulation::placeBodyParticles() {
  StageTimer timer(*this, Stage::RigidCoupling);
  // Poses of the moving bodies (centre of mass, orientation x y z w) and the fastest particle.
  std::vector<Eigen::Vector4f> pose(4 * moving_.size());
  body_speed_ = 0.0;
  for (std::size_t m = 0; m < moving_.size(); ++m) {
    const rigid::BodyState& s = bodies_[moving_[m]];
    pose[4 * m] = Eigen::Vector4f(float(s.x.x()), float(s.x.y()), float(s.x.z()), 0.0f);
    pose[4 * m + 1] = Eigen::Vector4f(float(s.q.x()), float(s.q.y()), float(s.q.z()), float(s.q.w()));
    pose[4 * m + 2] = Eigen::Vector4f(float(s.v.x()), float(s.v.y()), float(s.v.z()), 0.0f);
    pose[4 * m + 3] = Eigen::Vector4f(float(s.w.x()), float(s.w.y()), float(s.w.z()), 0.0f);
    body_speed_ = std::max(body_speed_, s.v.norm() + s.w.norm() * moving_reach_[m]);
  }
  clCall("uploading body poses",
         [&] { return cl_.queue().enqueueWriteBuffer(bpose_, CL_TRUE, 0, pose.size() * 16, pose.data()); });
  kernels_.call("rigid_transform", n_moving_, kLocal, n_moving_, n_static_, blocal_, bbody_, bpose_, bslot_, bsrc_, bpos_, bvel_);
}

void Simulation::sortBoundary() {
  StageTimer timer(*this, on(Stage::RigidCoupling) ? Stage::RigidCoupling : Stage::ClothCoupling);
  // The same counting sort as the fluid's (grid.cl), over all boundary particles.
  SimParams pb = params_;
  pb.n_fluid = n_static_ + n_moving_ + n_cloth_;
  const uint32_t zero = 0;
  clCall("clearing the boundary cell counts",
         [&] { return cl_.queue().enqueueFillBuffer(bcount_, zero, 0, std::size_t(params_.num_cells) * 4); });
  kernels_.call("grid_assign", pb.n_fluid, kLocal, pb, bsrc_, bcell_, brank_, bcount_);
  prefix_sum_.run(bcount_, bcell_start_, params_.num_cells);
  kernels_.call("grid_scatter", pb.n_fluid, kLocal, pb, bcell_, brank_, bcell_start_, bsorted_);
  kernels_.call("grid_order_cells", pb.n_fluid, kLocal, pb, bcell_, bcell_start_, bsorted_);
  // Positions and velocities in the new order (the bodies' rigid motion, zero on static particles;
  // before issue 15 the velocities kept the old order for one step after each sort).
  kernels_.call("rigid_boundary_reorder", pb.n_fluid, kLocal, pb.n_fluid, n_static_, n_moving_, bsorted_, bsrc_, blocal_,
                bbody_, bpose_, bpos_, bvel_, bslot_);
  if (n_sampled_ > 0)  // the static bodies' normals in the new order (zero on every other particle)
    kernels_.call("boundary_reorder_static", pb.n_fluid, kLocal, pb.n_fluid, n_static_, bsorted_, bnormal_src_, bnormal_);
  // The cloth nodes' velocities in the new order.
  if (on(Stage::ClothCoupling)) kernels_.call("cloth_to_boundary", n_cloth_, kLocal, n_cloth_, n_static_ + n_moving_, cloth_->positions(), cloth_->velocities(), cloth_volume_, bslot_, bsrc_, bpos_, bvel_, max_speed_);
}

void Simulation::gatherBodyForces() {
  StageTimer timer(*this, Stage::RigidCoupling);
  const int viscous = on(Stage::Viscosity) ? 1 : 0;
  // DFSPH: the wall mirrors the fluid's pressure, no contact term, and the viscous reaction uses the
  // velocities the fluid's viscous forces saw (before the density solve changed them). WCSPH: the boundary
  // velocities of the fluid's viscous pass (the no-slip ghost velocities or the wall's own).
  const int mirror = dfsphWallMode();
  const cl::Buffer& vel = dfsph_ ? dfsph_->viscousVelocities() : vel_[cur_];
  // fluid.body_ambient_pressure subtract (WCSPH, DFSPH's extrapolated walls): each body particle's running
  // mean pressure (weight dt / kBodyAmbientTime per step) and its pressure force per pascal, for the
  // reduction's reference. With DFSPH's strong body coupling the bodies moved inside the solves under
  // the plain pair sum; the correction acts here, on the force the body is integrated with (session 33).
  const int ambient = model_.body_ambient_subtract ? 1 : 0;
  const float ambient_rate = ambient ? static_cast<float>(std::min(1.0, params_.dt / Model::kBodyAmbientTime)) : 0.0f;
  // With the implicit viscosity the free bodies were unknowns of its solve: their reaction is gathered at
  // the solved velocities (core/dfsph.cpp, viscositySolve), as the fluid's side was.
  const cl::Buffer* solved = dfsph_ ? dfsph_->nodeViscousVelocities() : nullptr;
  kernels_.call("rigid_fluid_forces", n_moving_, kLocal, params_, n_moving_, n_static_, bsrc_, bslot_, solved ? *solved : viscousBoundaryVelocities(), bpressure_, pos_[cur_], vel, phase_[cur_], density_, pterm_, cell_start_, viscous, mirror, 0.0f, 0.0f, bforce_, ambient_rate, bgeo_, bpmean_);
  // The per-body reduction is timed on its own (profile.rigid_reduce_seconds).
  clCall("waiting for the body forces", [&] { return cl_.queue().finish(); });
  const auto t_reduce = std::chrono::steady_clock::now();
  const uint32_t nb = static_cast<uint32_t>(moving_.size());
  kernels_.call("rigid_reduce", nb, 0, nb, n_static_, brange_, bpose_, bsrc_, bforce_, ambient, bgeo_, cl_float4{{params_.gravity[0], params_.gravity[1], params_.gravity[2], params_.phase_rest_density[0]}}, bsum_);
  // Only force and torque per body cross to the host.
  std::vector<Eigen::Vector4f> sums(2 * nb);
  clCall("reading body forces",
         [&] { return cl_.queue().enqueueReadBuffer(bsum_, CL_TRUE, 0, sums.size() * 16, sums.data()); });
  profile_.rigid_reduce_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t_reduce).count();
  for (uint32_t m = 0; m < nb; ++m) {
    rigid::BodyState& s = bodies_[moving_[m]];
    s.fluid_force = sums[2 * m].head<3>().cast<double>();
    s.fluid_torque = sums[2 * m + 1].head<3>().cast<double>();
    if (record_forces_) step_forces_.push_back({time_, moving_[m], s.v, s.w, s.fluid_force, s.fluid_torque});
  }
}

void Simulation::applyExternalForces(double dt) {
  StageTimer timer(*this, Stage::Haptics);
  // One wrench per body from the source (core/external_force.h), kept in the states for this step.
  wrenches_.assign(bodies_.size(), BodyWrench{});
  external_->apply(time_, dt, model_.bodies, bodies_, wrenches_);
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    bodies_[b].external_force = wrenches_[b].force;
    bodies_[b].external_torque = wrenches_[b].torque;
    bodies_[b].external_damping = wrenches_[b].damping;
  }
}

bool Simulation::heldBody(std::size_t b) const {
  // A dynamic body with hold_until is held still at its pose until then.
  return model_.bodies[b].kind == rigid::BodyKind::Dynamic && time_ < model_.bodies[b].spec.hold_until;
}

void Simulation::addedMassReaction(double dt) {
  // DFSPH: a dynamic body's fictitious mass M = C rho0 V (C = fluid.dfsph.body_added_mass, rho0
  // the first phase's rest density, V the body's volume). The incompressible solve answers the
  // body's last step's motion at once (the fluid is made divergence-free about the body's velocity
  // at the step's start), so a staggered update sees the added mass one step late: a_n = (F0 -
  // m_a a_{n-1}) / m, which flips and grows where m_a > m (a 500 kg/m^3 ball in water: measured
  // period-2 swings of +-6 rho g V within 6 steps of its release). M in the body's inertia and
  // M a_{n-1} in its force (Baek & Karniadakis 2012, eq. 9) make the ratio (M - m_a) / (m + M).
  // The body then feels F_M = M (a_{n-1} - a_n) besides the gathered force: the added-mass
  // reaction to its change of acceleration that the solve answers only next step. It is the
  // fluid's force, so the fluid takes -F_M dt now (kernels/rigid.cl, (4)): the total momentum is
  // conserved, and the body's reported fluid force includes F_M (integrateBodies).
  const double c_rho = dfsph_ && !model_.spec.fluid.phases.empty()
                           ? model_.spec.fluid.dfsph.body_added_mass * model_.spec.fluid.phases[0].rest_density
                           : 0.0;  // C rho0 (unit: kg/m^3)
  // With the strong body coupling the bodies move inside the solves: no lag, no fictitious mass.
  if (c_rho == 0.0 || n_moving_ == 0 || strongBodies()) return;
  bool free_body = false;
  for (std::size_t b : moving_) free_body = free_body || (model_.bodies[b].kind == rigid::BodyKind::Dynamic && !heldBody(b));
  if (!free_body) return;
  StageTimer timer(*this, Stage::RigidCoupling);
  const uint32_t nb = static_cast<uint32_t>(moving_.size());
  if (!bweight_()) {
    bweight_ = makeBuffer(n_moving_ * 4);
    bweight_sum_ = makeBuffer(nb * 4);
    bshare_ = makeBuffer(nb * 16);
  }
  // The fluid within H of each body, weighed as its reaction will be spread: S = sum_b psi_b
  // sum_i m_i W_ib, summed per body in particle order (deterministic); one float per body to the host.
  kernels_.call("rigid_wet_weight", n_moving_, kLocal, params_, n_moving_, n_static_, bsrc_, pos_[cur_], phase_[cur_], cell_start_, bweight_);
  kernels_.call("rigid_reduce_weight", nb, 0, nb, brange_, bweight_, bweight_sum_);
  std::vector<float> S(nb);
  clCall("reading the bodies' fluid weights",
         [&] { return cl_.queue().enqueueReadBuffer(bweight_sum_, CL_TRUE, 0, nb * 4, S.data()); });
  // Each free dynamic body with fluid within H: M, F_M (rigid::fictitiousForce, the forces of this
  // step as integrateBodies will take them) and the fluid's share -F_M dt / S. A body with no fluid
  // near (falling through air) has no added mass: M = 0.
  const Eigen::Vector3d g = gravityAt(model_.spec.simulation, time_);
  added_mass_.assign(bodies_.size(), 0.0);
  std::vector<Eigen::Vector4f> share(nb, Eigen::Vector4f::Zero());
  const std::size_t first_record = step_forces_.size() >= nb ? step_forces_.size() - nb : 0;
  for (uint32_t m = 0; m < nb; ++m) {
    const std::size_t b = moving_[m];
    rigid::BodyState& s = bodies_[b];
    s.added_mass_force.setZero();
    if (model_.bodies[b].kind != rigid::BodyKind::Dynamic || heldBody(b) || !(S[m] > 0.0f)) continue;
    added_mass_[b] = c_rho * model_.bodies[b].volume;
    s.added_mass_force = rigid::fictitiousForce(model_.bodies[b], s, g, added_mass_[b], dt);
    share[m].head<3>() = (-dt * s.added_mass_force / static_cast<double>(S[m])).cast<float>();
    // The per-step force log (gatherBodyForces recorded this step's bodies last, in this order).
    if (record_forces_ && first_record + m < step_forces_.size()) step_forces_[first_record + m].force += s.added_mass_force;
  }
  // The reaction: each fluid particle gathers its share from the body particles within H.
  clCall("uploading the fictitious-mass reactions",
         [&] { return cl_.queue().enqueueWriteBuffer(bshare_, CL_TRUE, 0, nb * 16, share.data()); });
  kernels_.call("rigid_added_mass_reaction", n_, kLocal, params_, n_static_, n_moving_, pos_[cur_], bpos_, sbnbr_, sbnbr_count_, bsorted_, bbody_, bshare_, vel_[cur_]);
}

void Simulation::integrateBodies(double dt) {
  StageTimer timer(*this, Stage::RigidDynamics);
  // Gravity at the start of the step, as the fluid sees it (in double: the host integrates in double).
  const Eigen::Vector3d g = gravityAt(model_.spec.simulation, time_);
  // In water the bodies touch the closed walls across a film of one spacing (body_walls_: the
  // contact and the position update see the walls moved in by Model::wall_film).
  const DomainSpec* walls = &body_walls_;
  // Momenta from gravity and the fluid; contact impulses between bodies and with the closed walls
  // (core/contact.h); poses (keyframed bodies: the pose at the end of the step from the path
  // itself, no drift); penetration removed by split impulses.
  // A dynamic body with hold_until is held still at its pose until then (its fluid force is still
  // gathered, as a held body's), and released from rest after: the fluid settles around it first.
  // DFSPH: a dynamic body's fictitious mass M of this step (addedMassReaction; 0 = none), whose
  // force F_M = M (a_{n-1} - a_n) the fluid has taken back already; it counts in the body's fluid
  // force once the body has moved. The acceleration kept for the next step is the forces' own,
  // before the contact impulses: at rest on a floor it tends to F / m, and F_M to 0 (with the
  // contacts in, a_{n-1} = 0 there, and F_M = -M F / (m + M) would push the fluid every step).
  // The same for the rotation (the fictitious inertia (M / m) I): torque_rate, and the torque
  // T_J = M (tau_{n-1} - T_n) / (m + M) in the body's fluid torque, which the fluid does not take back.
  std::vector<Eigen::Vector3d> v_before(bodies_.size());
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    rigid::BodyState& s = bodies_[b];
    v_before[b] = s.v;
    const Eigen::Vector3d L_before = s.L;
    const double M = b < added_mass_.size() ? added_mass_[b] : 0.0;
    s.added_mass_torque = rigid::fictitiousTorque(model_.bodies[b], s, M, g, dt);
    if (!heldBody(b)) rigid::integrateVelocity(model_.bodies[b], s, g, dt, M);
    s.accel = heldBody(b) ? Eigen::Vector3d::Zero() : Eigen::Vector3d((s.v - v_before[b]) / dt);
    s.torque_rate = heldBody(b) ? Eigen::Vector3d::Zero() : Eigen::Vector3d((s.L - L_before) / dt);
    if (M > 0.0) {
      s.fluid_force += s.added_mass_force;
      s.fluid_torque += s.added_mass_torque;
    } else {
      s.added_mass_force.setZero();
    }
  }
  added_mass_.clear();
  // Contacts and positions in substeps of at most simulation.contact_step (0: one per step), the forces'
  // velocity change above applied once. One contact solve per long step damps rolling (a ball in the bowl
  // at 1/120 s steps swung 16 % slow and stopped within 1.5 s; with 0.5 ms contact substeps within 2 % of a
  // rolling sphere's period: docs/forces.md, session 40). With substeps, contact_force is the step's mean.
  const double hmax = model_.spec.simulation.contact_step;
  const int k = hmax > 0.0 ? std::max(1, static_cast<int>(std::ceil(dt / hmax - 1e-9))) : 1;
  const double h = dt / k;
  std::vector<Eigen::Vector3d> mean_contact;  // k > 1 only: one step is bitwise as before
  if (k > 1) mean_contact.assign(bodies_.size(), Eigen::Vector3d::Zero());
  for (int j = 0; j < k; ++j) {
    contacts_->solve(model_.bodies, bodies_, walls, g, h);
    for (std::size_t b = 0; b < mean_contact.size(); ++b) mean_contact[b] += (h / dt) * bodies_[b].contact_force;
    for (std::size_t b = 0; b < bodies_.size(); ++b) {
      if (heldBody(b)) {
        bodies_[b].v.setZero();
        bodies_[b].w.setZero();
        bodies_[b].L.setZero();
        continue;
      }
      rigid::integratePosition(model_.bodies[b], bodies_[b], h, walls);
      if (model_.bodies[b].kind == rigid::BodyKind::Kinematic && model_.bodies[b].spec.motion.type == MotionType::Keyframes)
        rigid::followKeyframes(model_.bodies[b], bodies_[b], time_ + (j + 1) * h);
    }
    contacts_->correctPositions(model_.bodies, bodies_, h);
  }
  for (std::size_t b = 0; b < mean_contact.size(); ++b) bodies_[b].contact_force = mean_contact[b];
}

// --- Cloth (core/cloth.h, kernels/cloth.cl) ----------------------------------------------------

void Simulation::stepCloth(double dt) {
  StageTimer timer(*this, Stage::Cloth);
  // With fluid, the nodes carry the fluid's force of this step (gatherClothForces).
  // Balls (rigid spheres) are obstacles for the nodes; the nodes' impulses change the balls' momenta.
  std::vector<std::size_t> which;
  const std::vector<cloth::SphereCollider> spheres = clothSpheres(&which);
  const std::vector<Eigen::Vector3d> J =
      cloth_->step(time_, dt, gravityAt(model_.spec.simulation, time_), n_cloth_ > 0 ? &cloth_force_ : nullptr, spheres);
  for (std::size_t k = 0; k < which.size(); ++k)
    if (model_.bodies[which[k]].kind == rigid::BodyKind::Dynamic) bodies_[which[k]].v += J[k] / model_.bodies[which[k]].mass;
  // Boxes, cylinders, capsules and meshes push the nodes out (host side).
  if (!cloth_obstacles_.empty()) collideClothWithBodies();
  // Cutters at their new pose break the springs their surfaces cross.
  if (!cutters_.empty()) {
    std::vector<cloth::CutterPose> poses;
    for (std::size_t b : cutters_) poses.push_back({bodies_[b].x, bodies_[b].q});
    cloth_->cut(poses);
  }
}

std::vector<cloth::SphereCollider> Simulation::clothSpheres(std::vector<std::size_t>* which) const {
  std::vector<cloth::SphereCollider> spheres;
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    const rigid::RigidBody& body = model_.bodies[b];
    if (body.spec.shape != BodyShape::Sphere) continue;
    spheres.push_back({bodies_[b].x, body.spec.radius * body.spec.scale, bodies_[b].v, body.spec.friction});
    if (which) which->push_back(b);
  }
  return spheres;
}

void Simulation::collideClothWithBodies() {
  // Contact of the nodes with bodies of any closed shape, after the cloth solve (particle
  // coupling, as for balls; Mueller et al. 2007, collision constraints): a free node inside a body
  // moves to the closest point of its surface (ClosedSurface: inside test by pseudo-normals,
  // Baerentzen & Aanaes 2005) and loses its velocity into the body relative to the body's surface
  // point (inelastic), with Coulomb friction (the body's coefficient). A dynamic body receives the
  // opposite impulse. Host side in node order, then body order: deterministic. It reads the nodes
  // back once per step (16 bytes per node each way).
  std::vector<Eigen::Vector4f> x, v;
  cloth_->read(x, v);
  bool moved = false;
  for (const auto& [b, surface] : cloth_obstacles_) {
    const rigid::RigidBody& body = model_.bodies[b];
    rigid::BodyState& s = bodies_[b];
    const Eigen::Matrix3d R = s.q.toRotationMatrix();
    // A cheap reject: nodes farther from the centre than the mesh's largest radius.
    double reach = 0;
    for (const Eigen::Vector3f& p : body.mesh.positions) reach = std::max(reach, double(p.norm()));
    Eigen::Vector3d J = Eigen::Vector3d::Zero(), T = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (x[i].w() == 0.0f) continue;  // anchored
      const Eigen::Vector3d p = x[i].head<3>().cast<double>();
      const Eigen::Vector3d local = R.transpose() * (p - s.x);
      if (local.norm() > reach) continue;
      if (!surface->inside(local)) continue;
      const SurfaceIndex::Nearest hit = surface->index().nearest(local);
      const Eigen::Vector3d n = R * surface->pseudoNormal(hit.triangle, hit.feature);  // outward, world
      const Eigen::Vector3d q = s.x + R * hit.point;
      // Position: onto the surface. Velocity: no approach relative to the surface point.
      const Eigen::Vector3d r = q - s.x, vb = s.v + s.w.cross(r);
      Eigen::Vector3d vi = v[i].head<3>().cast<double>();
      const Eigen::Vector3d rel = vi - vb;
      const double vn = rel.dot(n);
      if (vn < 0) {
        const Eigen::Vector3d vt = rel - vn * n;
        const double st = vt.norm();
        const double keep = st > 0 ? std::max(0.0, 1.0 - body.spec.friction * (-vn) / st) : 0.0;
        const Eigen::Vector3d dv = -vn * n - (1.0 - keep) * vt;
        vi += dv;
        const Eigen::Vector3d Ji = -static_cast<double>(model_.cloth.mass[i]) * dv;  // on the body
        J += Ji;
        T += r.cross(Ji);
      }
      x[i].head<3>() = q.cast<float>();
      v[i].head<3>() = vi.cast<float>();
      moved = true;
    }
    if (body.kind == rigid::BodyKind::Dynamic) {
      s.v += J / body.mass;
      s.L += T;
      s.w = rigid::worldInverseInertia(body, s.q) * s.L;
    }
  }
  if (moved) cloth_->write(x, v);
}

void Simulation::placeClothParticles() {
  StageTimer timer(*this, Stage::ClothCoupling);
  // Node positions and velocities into the boundary buffers; their speed joins the step's largest
  // (the Verlet-list skin, integrate()).
  kernels_.call("cloth_to_boundary", n_cloth_, kLocal, n_cloth_, n_static_ + n_moving_, cloth_->positions(), cloth_->velocities(), cloth_volume_, bslot_, bsrc_, bpos_, bvel_, max_speed_);
}

bool Simulation::strongCloth() const {
  // DFSPH's strong cloth coupling (fluid.dfsph.cloth_coupling: strong): the free nodes move under the
  // pressure inside the solves' iterations (kernels/dfsph.cl, dfsph_node_accel). Not with mirrored
  // walls (core/dfsph.cpp, factors()).
  return dfsph_ && n_cloth_ > 0 && on(Stage::ClothCoupling) && on(Stage::Cloth) &&
         model_.spec.fluid.dfsph.cloth_coupling == DfsphCoupling::Strong;
}

bool Simulation::strongBodies() const {
  // DFSPH's strong body coupling (fluid.dfsph.body_coupling: strong): the free dynamic bodies move
  // under the pressure inside the solves' iterations (kernels/dfsph.cl, dfsph_body_accel). Not with
  // mirrored walls (as the cloth's). While every dynamic body is held (hold_until: the settle before a
  // release) nothing moves in the solves, but they keep the strong path's stop (at least
  // kBodyStopGap iterations after a coarse correction, core/dfsph.cpp): the tank a body is released
  // into is then settled as well as the run after the release solves it, and a held reference run
  // is solved as the free one (session 26 tried the staggered path for held steps: the force checks'
  // held-subtracted drag C_d at R/dx 4 went from 0.73 to 1.36, band top 0.91; docs/forces.md).
  // Kinematic bodies alone (a prescribed motion) have nothing to move in the solves: no extra passes.
  if (!dfsph_ || n_moving_ == 0 || !on(Stage::RigidCoupling) || !on(Stage::RigidDynamics) ||
      model_.spec.fluid.dfsph.body_coupling != DfsphCoupling::Strong || model_.spec.fluid.dfsph.walls == DfsphWalls::Mirrored)
    return false;
  for (std::size_t b : moving_)
    if (model_.bodies[b].kind == rigid::BodyKind::Dynamic) return true;
  return false;
}

void Simulation::bodyResponse(double dt) {
  // Per moving body, what the solves need to move it with the pressure (kernels/shared/body_response.h):
  // its centre, its mobility N over this step (rigid::mobility: diag(1 / m, I_w^-1), or with a haptic
  // grab's spring-damper implicit in it), and its acceleration without the fluid's pressure, N times
  // gravity's force, this step's external wrench (applyExternalForces runs first) and the last step's
  // contact forces (a body resting on the floor is held there by its contacts). A body that does not
  // move in the solves (held, kinematic) is marked so (free = 0).
  StageTimer timer(*this, Stage::RigidCoupling);
  const Eigen::Vector3d g = gravityAt(model_.spec.simulation, time_);
  constexpr std::size_t S = DFSPH_BODY_STRIDE;
  std::vector<Eigen::Vector4f> data(S * moving_.size(), Eigen::Vector4f::Zero());
  for (std::size_t m = 0; m < moving_.size(); ++m) {
    const std::size_t b = moving_[m];
    const rigid::RigidBody& body = model_.bodies[b];
    const rigid::BodyState& s = bodies_[b];
    data[S * m].head<3>() = s.x.cast<float>();
    if (body.kind != rigid::BodyKind::Dynamic || heldBody(b) || !(body.mass > 0.0)) continue;
    const rigid::Matrix6d N = rigid::mobility(body, s, dt);
    rigid::Vector6d dry;
    dry.head<3>() = body.mass * g + s.contact_force + s.external_force;
    dry.tail<3>() = s.contact_torque + s.external_torque;
    const rigid::Vector6d a_dry = N * dry;
    data[S * m].w() = 1.0f;
    data[S * m + 1] << a_dry.head<3>().cast<float>(), static_cast<float>(moving_reach_[m]);  // w: the body's reach (its error's rotation part)
    data[S * m + 2].head<3>() = a_dry.tail<3>().cast<float>();
    for (int r = 0; r < 6; ++r) {
      data[S * m + 3 + 2 * r].head<3>() = N.block<1, 3>(r, 0).transpose().cast<float>();
      data[S * m + 4 + 2 * r].head<3>() = N.block<1, 3>(r, 3).transpose().cast<float>();
    }
  }
  if (!bdata_()) bdata_ = makeBuffer(data.size() * 16);
  clCall("uploading the bodies' responses",
         [&] { return cl_.queue().enqueueWriteBuffer(bdata_, CL_TRUE, 0, data.size() * 16, data.data()); });
}

void Simulation::clothResponse(double dt) {
  // Each node's M^-1 for this step (kernels/cloth.cl, cloth_node_response): its mass with its springs
  // implicit, so that the solves move a node of a taut or sagging sheet as little as its springs let
  // it move, and a flat sheet's node across itself as freely as its mass does.
  StageTimer timer(*this, Stage::ClothCoupling);
  clothAddedMass();
  if (!node_response_()) node_response_ = makeBuffer(std::size_t(n_cloth_) * 48);
  cloth_->nodeResponse(dt, node_response_);
  // What the cloth's own forces (gravity, springs, anchors, damping, balls) do to the nodes in this
  // step, for the density solve to see them move as the fluid sees itself at v* (core/dfsph.cpp,
  // densitySolve): a dry run of the cloth's step, its state kept. (Boxes, meshes and cutters, which
  // act on the nodes from the host after the step, are not in it.)
  if (!node_dv_()) node_dv_ = makeBuffer(std::size_t(n_cloth_) * 16);
  cloth_->dryVelocityChange(time_, dt, gravityAt(model_.spec.simulation, time_), clothSpheres(nullptr), node_dv_);
}

// DFSPH's added mass of wet cloth nodes (clothAddedMass): a node has all of it with at least this
// fraction of rho0 of fluid in its support (sum_i m_i W_ik), less in proportion below (a few drops).
// A tenth: the sealed column's nodes (water on both sides, a spacing off) have 0.1-0.25 and flutter
// unless they all have it (docs/dfsph.md, session 19).
static constexpr double kAddedMassWetFraction = 0.1;  // (unit: 1)

void Simulation::clothAddedMass() {
  // DFSPH's added mass of wet cloth nodes (fluid.dfsph.cloth_added_mass = C; 0 = off). With the
  // strong coupling a light node with water on both sides moves in the solves as its mass (or with
  // its springs implicit), while its own step resolves stiff springs in substeps that the solves
  // see only through their end: the sealed sheet of scenes/tests/dfsph_cloth_sandwich.yaml at 0.5 ms
  // substeps flutters with period ~2 steps at ~0.13 m/s (its nodes' velocities alternate in sign
  // from step to step) and rests once its areal density is ~8x (docs/dfsph.md, session 19). In a
  // step the cloth takes in substeps, each free wet node gets M_k = C rho0 V_k (V_k = psi_k dx^3, the
  // fluid volume its boundary particle stands for; scaled down where it has less than a tenth of a
  // full support of fluid, kernels/dfsph.cl) in its own step and in the solves' response: its
  // inertia, not its weight, so where it rests is unchanged. The fluid near it takes the momentum
  // M_k (v' - v) of the last step (kernels/dfsph.cl, dfsph_node_added_mass_reaction), so the total
  // is conserved.
  const double C = model_.spec.fluid.dfsph.cloth_added_mass;
  if (!(C > 0.0)) return;
  if (!node_share_()) node_share_ = makeBuffer(std::size_t(n_cloth_) * 16);
  const double rho0 = model_.spec.fluid.phases.empty() ? 1000.0 : model_.spec.fluid.phases[0].rest_density;
  // Only where the cloth's step is split (cloth[].max_time_step): one soft XPBD step damps what the
  // solves miss, and needs none (the column rests in one step; a hammock's pool spilled more with it).
  const bool split = cloth_->xpbdSubsteps(params_.dt) > 1;
  const float c_rho_v0 = split ? static_cast<float>(C * rho0 * model_.dx * model_.dx * model_.dx) : 0.0f;
  const float wet_rho = static_cast<float>(kAddedMassWetFraction * rho0);
  const uint32_t offset = n_static_ + n_moving_;
  kernels_.call("dfsph_node_added_mass", n_cloth_, kLocal, params_, n_cloth_, offset, cloth_->positions(), bsrc_,
                pos_[cur_], phase_[cur_], cell_start_, cloth_->rowStart(), cloth_->others(), cloth_->xpbdNodes(), c_rho_v0, wet_rho,
                cloth_->addedMassImpulse(), cloth_->addedMass(), node_share_);
  kernels_.call("dfsph_node_added_mass_reaction", n_, kLocal, params_, offset, n_cloth_, pos_[cur_], bpos_, sbnbr_,
                sbnbr_count_, bsorted_, node_share_, vel_[cur_]);
}

void Simulation::gatherClothForces() {
  StageTimer timer(*this, Stage::ClothCoupling);
  // The rigid bodies' per-particle kernel (rigid.cl, rigid_fluid_forces) serves the nodes as well:
  // each node gathers the reaction to the pressure, contact and viscous forces it exerts on its
  // fluid neighbours (equal and opposite). No reduction: the cloth integrates per node.
  // With DFSPH the same choices as for bodies (gatherBodyForces): mirrored pressure, and the
  // velocities the fluid's viscous forces saw.
  const int viscous = on(Stage::Viscosity) ? 1 : 0;
  const int mirror = dfsphWallMode();
  const cl::Buffer& vel = dfsph_ ? dfsph_->viscousVelocities() : vel_[cur_];
  // DFSPH's extrapolated walls push the fluid off the nodes too (dfsph_wall_contact_accel): the nodes
  // take that contact's reaction.
  const float contact = dfsph_ ? dfsph_->wallContactStiffness() : 0.0f;
  // With the implicit viscosity the nodes were unknowns of its solve: their reaction is gathered at the
  // solved velocities (core/dfsph.cpp, viscositySolve), as the fluid's side was.
  const cl::Buffer* solved = dfsph_ ? dfsph_->nodeViscousVelocities() : nullptr;
  kernels_.call("rigid_fluid_forces", n_cloth_, kLocal, params_, n_cloth_, n_static_ + n_moving_, bsrc_, bslot_, solved ? *solved : viscousBoundaryVelocities(), bpressure_, pos_[cur_], vel, phase_[cur_], density_, pterm_, cell_start_, viscous, mirror, contact, DfsphSolver::wallContactRange(), cloth_force_, 0.0f, cloth_force_, cloth_force_);  // ambient 0: geo and pmean unused
}

FrameReport Simulation::runDiagnostics() {
  StageTimer timer(*this, Stage::Diagnostics);
  FrameReport rep;
  params_.n_fluid = static_cast<sph_uint>(n_);
  const uint32_t chunk = static_cast<uint32_t>((n_ + diag_groups_ - 1) / diag_groups_);
  std::vector<uint32_t> out(diag_groups_ * 8, 0);
  uint32_t crossings = 0, overflow = 0;
  if (n_ > 0) {
    kernels_.call("diagnostics", diag_groups_, 0, params_, chunk, pos_[cur_], vel_[cur_], density_, diag_);
    clCall("reading diagnostics", [&] {
      auto& q = cl_.queue();
      q.enqueueReadBuffer(diag_, CL_TRUE, 0, out.size() * 4, out.data());
      q.enqueueReadBuffer(crossings_, CL_TRUE, 0, 4, &crossings);
      q.enqueueReadBuffer(overflow_, CL_TRUE, 0, 4, &overflow);
      const uint32_t zero = 0;
      q.enqueueWriteBuffer(crossings_, CL_TRUE, 0, 4, &zero);
      q.enqueueWriteBuffer(overflow_, CL_TRUE, 0, 4, &zero);
    q.enqueueWriteBuffer(max_speed_, CL_TRUE, 0, 4, &zero);
      return 0;
    });
  }
  // Sum the partial results in a fixed order.
  uint32_t first_bad = 0xffffffffu;
  for (uint32_t g = 0; g < diag_groups_; ++g) {
    const uint32_t* o = &out[g * 8];
    rep.nonfinite += o[0];
    rep.outside += o[1];
    rep.cfl_violations += o[2];
    float v;
    std::memcpy(&v, &o[4], 4);
    rep.max_speed = std::max(rep.max_speed, v);
    if (first_bad == 0xffffffffu && o[5] != 0xffffffffu) first_bad = o[5];
  }
  rep.wall_crossings = crossings;
  // A neighbour list overflowed during this frame: the extra neighbours were ignored; grow the lists
  // (and rebuild them at the next step).
  if (overflow > 0) {
    const uint32_t slots = (overflow + overflow / 4 + 7) / 8 * 8;
    std::ostringstream s;
    s << "a particle had " << overflow << " neighbours, more than the " << params_.max_neighbours
      << " list slots: the extra ones were ignored this frame; lists grown to " << slots << " slots";
    pending_messages_.push_back(s.str());
    allocateNeighbourLists(slots);
    lists_valid_ = false;
  }
  if (first_bad != 0xffffffffu) {
    uint32_t id = 0;
    clCall("reading a particle id",
           [&] { return cl_.queue().enqueueReadBuffer(id_[cur_], CL_TRUE, first_bad * 4, 4, &id); });
    rep.first_bad_id = id;
  }
  last_max_speed_ = std::isfinite(rep.max_speed) ? rep.max_speed : 0.0f;
  return rep;
}

// --- Isosurface (once per output frame, when the scene asks for it) ---------------------------

std::vector<TriMesh> Simulation::surfaceMeshes(const IsoSettings& settings) {
  if (!mesher_) mesher_ = std::make_unique<SurfaceMesher>(cl_, kernels_);
  params_.n_fluid = static_cast<sph_uint>(n_);
  // The grid of the last step (or of prepareInitialState) stays consistent with the particle
  // order; the field's gather allows for the drift since then. The mesher reads the state only.
  SPH_ASSERT(n_ == 0 || grid_built_, "isosurface before any neighbour grid");
  ParticleView view;
  view.params = &params_;
  view.pos = &pos_[cur_];
  view.phase = &phase_[cur_];
  view.colour = &colour_[cur_];
  view.cell_start = &cell_start_;
  view.count = n_;
  view.num_phases = static_cast<uint32_t>(std::max<std::size_t>(1, model_.spec.fluid.phases.size()));
  // bounds every particle's distance from where it was sorted (capped: a NaN run must not hang here)
  view.drift = std::min(travel_since_build_, 4.0 * model_.support);
  return mesher_->meshParticles(view, settings);
}

// --- Read-back ---------------------------------------------------------------------------------

void Simulation::readBodyParticles(std::vector<Eigen::Vector4f>& pos, std::vector<Eigen::Vector4f>& force) {
  pos.assign(n_moving_, Eigen::Vector4f::Zero());
  force.assign(n_moving_, Eigen::Vector4f::Zero());
  if (n_moving_ == 0) return;
  // The moving particles in bsrc order (after the static ones), their sorted slots, and the wall
  // pressures in sorted order.
  const std::size_t n_bnd = n_static_ + n_moving_ + n_cloth_;
  std::vector<uint32_t> slot(n_bnd);
  std::vector<float> pb(n_bnd);
  clCall("reading the body particles", [&] {
    auto& q = cl_.queue();
    q.enqueueReadBuffer(bsrc_, CL_FALSE, std::size_t(n_static_) * 16, std::size_t(n_moving_) * 16, pos.data());
    q.enqueueReadBuffer(bforce_, CL_FALSE, 0, std::size_t(n_moving_) * 16, force.data());
    q.enqueueReadBuffer(bslot_, CL_FALSE, 0, n_bnd * 4, slot.data());
    q.enqueueReadBuffer(bpressure_, CL_FALSE, 0, n_bnd * 4, pb.data());
    q.finish();
    return 0;
  });
  for (uint32_t k = 0; k < n_moving_; ++k) force[k].w() = pb[slot[n_static_ + k]];
}

ParticleFrame Simulation::readFrame() {
  ParticleFrame f;
  f.time = time_;
  const std::size_t n = n_;
  std::vector<Eigen::Vector4f> pos(n), vel(n), col(n);
  std::vector<float> rho(n), p(n);
  std::vector<uint32_t> ph(n), id(n);
  if (n > 0) {
    clCall("reading particles", [&] {
      auto& q = cl_.queue();
      q.enqueueReadBuffer(pos_[cur_], CL_FALSE, 0, n * 16, pos.data());
      q.enqueueReadBuffer(vel_[cur_], CL_FALSE, 0, n * 16, vel.data());
      q.enqueueReadBuffer(colour_[cur_], CL_FALSE, 0, n * 16, col.data());
      q.enqueueReadBuffer(density_, CL_FALSE, 0, n * 4, rho.data());
      q.enqueueReadBuffer(pressure_, CL_FALSE, 0, n * 4, p.data());
      q.enqueueReadBuffer(phase_[cur_], CL_FALSE, 0, n * 4, ph.data());
      q.enqueueReadBuffer(id_[cur_], CL_FALSE, 0, n * 4, id.data());
      q.finish();
      return 0;
    });
  }
  f.x.resize(n); f.y.resize(n); f.z.resize(n);
  f.vx.resize(n); f.vy.resize(n); f.vz.resize(n);
  f.r.resize(n); f.g.resize(n); f.b.resize(n);
  f.density = std::move(rho);
  f.pressure = std::move(p);
  f.phase.resize(n);
  f.id.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    f.x[i] = pos[i].x(); f.y[i] = pos[i].y(); f.z[i] = pos[i].z();
    f.vx[i] = vel[i].x(); f.vy[i] = vel[i].y(); f.vz[i] = vel[i].z();
    f.r[i] = col[i].x(); f.g[i] = col[i].y(); f.b[i] = col[i].z();
    f.phase[i] = static_cast<int32_t>(ph[i]);
    f.id[i] = id[i];
  }
  return f;
}

uint64_t Simulation::stateHash() {
  const ParticleFrame f = readFrame();
  uint64_t h = 1469598103934665603ull;
  auto mix = [&](const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  };
  const std::size_t n = f.size();
  mix(&n, sizeof n);
  for (const auto* v : {&f.x, &f.y, &f.z, &f.vx, &f.vy, &f.vz, &f.r, &f.g, &f.b}) mix(v->data(), n * 4);
  mix(f.phase.data(), n * 4);
  mix(f.id.data(), n * 8);
  // Rigid bodies: pose and velocities (double precision, as integrated on the host).
  return rigid::hashStates(bodies_, h);
}

}  // namespace sph
