#include "core/simulation.h"

#include "core/errors.h"

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
  // Neighbour-list slots: 1.5x the particles within the list radius in the bulk at rest, plus 8.
  const double ratio = (model_.support + model_.skin) / model_.dx;
  allocateNeighbourLists(static_cast<uint32_t>((1.5 * 4.18879 * ratio * ratio * ratio + 8.0 + 7.0) / 8.0) * 8u);

  // Grid tables; the scan works in chunks of ~1k cells.
  cell_count_ = makeBuffer(cells * 4);
  cell_start_ = makeBuffer((cells + 1) * 4);
  prefix_sum_ = PrefixSum(cl_, kernels_);
  bpos_ = makeBuffer(model_.boundary.size() * 16);
  bcell_start_ = makeBuffer((cells + 1) * 4);
  crossings_ = makeBuffer(4);
  max_speed_ = makeBuffer(4);
  diag_groups_ = 64;
  diag_ = makeBuffer(diag_groups_ * 32);

  // Upload the static boundary and the initial particles.
  auto& q = cl_.queue();
  clCall("uploading the initial state", [&] {
    if (!model_.boundary.empty())
      q.enqueueWriteBuffer(bpos_, CL_TRUE, 0, model_.boundary.size() * 16, model_.boundary.data());
    q.enqueueWriteBuffer(bcell_start_, CL_TRUE, 0, (cells + 1) * 4, model_.boundary_cell_start.data());
    const uint32_t zero = 0;
    q.enqueueWriteBuffer(crossings_, CL_TRUE, 0, 4, &zero);
    q.enqueueWriteBuffer(overflow_, CL_TRUE, 0, 4, &zero);
    q.enqueueWriteBuffer(max_speed_, CL_TRUE, 0, 4, &zero);
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
  emitter_travel_.assign(model_.emitters.size(), model_.dx);  // the first layer leaves at the start time
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
  const Eigen::Vector3d g = gravityAt(model_.spec.simulation, time_);
  for (int a = 0; a < 3; ++a) params_.gravity[a] = static_cast<float>(g[a]);

  if (on(Stage::Inflow)) emitInflow(dt);  // new particles enter at the nozzles
  params_.n_fluid = static_cast<sph_uint>(n_);
  if (n_ > 0) {
    if (!lists_valid_ || travel_since_build_ > 0.5 * model_.skin)
      buildGrid();                                     // sort by cell, reorder, Verlet lists
    computeDensity();                                  // number density, rho, p (S&P 2008, Akinci 2012)
    pressureForces();                                  // -grad p / rho + g   (or g alone when disabled)
    if (on(Stage::Viscosity)) viscosityForces();       // Monaghan or Morris
    if (on(Stage::ColourDiffusion)) diffuseColour();   // colour mixing
    integrate();                                       // semi-implicit Euler, closed walls
  }
  time_ += dt;
  ++profile_.steps;
  profile_.particle_steps += n_;
}

FrameReport Simulation::advanceFrame() {
  const SimulationSpec& sim = model_.spec.simulation;
  // Time-step control: the scene's substeps, checked against the CFL and viscous limits
  // (Monaghan 1992: dt <= cfl h / (c0 + |v|max); Morris et al. 1997: dt <= 0.125 h^2 / nu).
  double limit = sim.cfl * model_.h / (model_.c0 + last_max_speed_);
  if (on(Stage::Viscosity) && model_.spec.fluid.viscosity_model == ViscosityModel::Laminar && model_.max_viscosity > 0)
    limit = std::min(limit, 0.125 * model_.h * model_.h / model_.max_viscosity);
  int steps = sim.substeps;
  double dt = model_.frame_dt / steps;
  if (dt > limit * (1.0 + 1e-9)) {
    if (sim.time_step_control == TimeStepControl::Subdivide) {
      steps = static_cast<int>(std::ceil(model_.frame_dt / limit));
      dt = model_.frame_dt / steps;
      ++profile_.subdivided_frames;
    } else {
      ++profile_.cfl_warned_frames;
    }
  }
  for (int k = 0; k < steps; ++k) step(dt);
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

  // Policy: abort on NaN/inf or a CFL violation, naming frame, time, stage and particle. Wall
  // crossings were already repaired (the particle is back inside): they are reported, not fatal.
  if (sim.numerical_errors == NumericalPolicy::Abort && (rep.nonfinite > 0 || rep.cfl_violations > 0)) {
    std::ostringstream s;
    s << "numerical failure at frame " << rep.frame << ", t = " << rep.time << " s: ";
    if (rep.nonfinite) s << rep.nonfinite << " particle(s) with NaN/inf (stage: integrate); ";
    if (rep.cfl_violations)
      s << rep.cfl_violations << " particle(s) moved more than h in one step (CFL, stage: integrate; dt = " << dt
        << " s); ";
    if (rep.first_bad_id >= 0) s << "first particle id " << rep.first_bad_id;
    throw NumericalError(s.str());
  }
  return rep;
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
  cl::Kernel& assign = kernels_["grid_assign"];
  assign.setArg(0, sizeof(SimParams), &params_);
  assign.setArg(1, pos_[cur_]);
  assign.setArg(2, cell_);
  assign.setArg(3, rank_);
  assign.setArg(4, cell_count_);
  kernels_.enqueue("grid_assign", n_, kLocal);
  prefix_sum_.run(cell_count_, cell_start_, params_.num_cells);
  cl::Kernel& scatter = kernels_["grid_scatter"];
  scatter.setArg(0, sizeof(SimParams), &params_);
  scatter.setArg(1, cell_);
  scatter.setArg(2, rank_);
  scatter.setArg(3, cell_start_);
  scatter.setArg(4, sorted_);
  kernels_.enqueue("grid_scatter", n_, kLocal);
  cl::Kernel& order = kernels_["grid_order_cells"];
  order.setArg(0, sizeof(SimParams), &params_);
  order.setArg(1, cell_);
  order.setArg(2, cell_start_);
  order.setArg(3, sorted_);
  kernels_.enqueue("grid_order_cells", n_, kLocal);
  // gather every field into cell order, then swap halves
  const int nxt = 1 - cur_;
  cl::Kernel& re = kernels_["grid_reorder"];
  re.setArg(0, sizeof(SimParams), &params_);
  re.setArg(1, sorted_);
  re.setArg(2, pos_[cur_]);
  re.setArg(3, vel_[cur_]);
  re.setArg(4, colour_[cur_]);
  re.setArg(5, phase_[cur_]);
  re.setArg(6, id_[cur_]);
  re.setArg(7, pos_[nxt]);
  re.setArg(8, vel_[nxt]);
  re.setArg(9, colour_[nxt]);
  re.setArg(10, phase_[nxt]);
  re.setArg(11, id_[nxt]);
  kernels_.enqueue("grid_reorder", n_, kLocal);
  cur_ = nxt;
  // neighbour lists within H + skin
  cl::Kernel& lists = kernels_["build_neighbour_lists"];
  lists.setArg(0, sizeof(SimParams), &params_);
  lists.setArg(1, pos_[cur_]);
  lists.setArg(2, cell_start_);
  lists.setArg(3, bpos_);
  lists.setArg(4, bcell_start_);
  lists.setArg(5, nbr_);
  lists.setArg(6, nbr_count_);
  lists.setArg(7, bnbr_);
  lists.setArg(8, bnbr_count_);
  lists.setArg(9, overflow_);
  kernels_.enqueue("build_neighbour_lists", n_, kLocal);
  lists_valid_ = true;
  travel_since_build_ = 0.0;
  ++profile_.grid_builds;
}

void Simulation::computeDensity() {
  StageTimer timer(*this, Stage::Density);
  cl::Kernel& k = kernels_["compute_density"];
  k.setArg(0, sizeof(SimParams), &params_);
  k.setArg(1, pos_[cur_]);
  k.setArg(2, phase_[cur_]);
  k.setArg(3, bpos_);
  k.setArg(4, nbr_);
  k.setArg(5, nbr_count_);
  k.setArg(6, bnbr_);
  k.setArg(7, bnbr_count_);
  k.setArg(8, density_);
  k.setArg(9, pressure_);
  k.setArg(10, pterm_);
  k.setArg(11, snbr_);
  k.setArg(12, snbr_count_);
  k.setArg(13, sbnbr_);
  k.setArg(14, sbnbr_count_);
  kernels_.enqueue("compute_density", n_, kLocal);
}

void Simulation::pressureForces() {
  StageTimer timer(*this, Stage::Pressure);
  if (!on(Stage::Pressure)) {  // gravity still acts
    cl::Kernel& k = kernels_["gravity_only"];
    k.setArg(0, sizeof(SimParams), &params_);
    k.setArg(1, acc_);
    kernels_.enqueue("gravity_only", n_, kLocal);
    return;
  }
  cl::Kernel& k = kernels_["pressure_force"];
  k.setArg(0, sizeof(SimParams), &params_);
  k.setArg(1, pos_[cur_]);
  k.setArg(2, phase_[cur_]);
  k.setArg(3, pterm_);
  k.setArg(4, snbr_);
  k.setArg(5, snbr_count_);
  k.setArg(6, bpos_);
  k.setArg(7, sbnbr_);
  k.setArg(8, sbnbr_count_);
  k.setArg(9, acc_);
  kernels_.enqueue("pressure_force", n_, kLocal);
}

void Simulation::viscosityForces() {
  StageTimer timer(*this, Stage::Viscosity);
  cl::Kernel& k = kernels_["viscosity_force"];
  k.setArg(0, sizeof(SimParams), &params_);
  k.setArg(1, pos_[cur_]);
  k.setArg(2, vel_[cur_]);
  k.setArg(3, phase_[cur_]);
  k.setArg(4, density_);
  k.setArg(5, snbr_);
  k.setArg(6, snbr_count_);
  k.setArg(7, acc_);
  kernels_.enqueue("viscosity_force", n_, kLocal);
}

void Simulation::diffuseColour() {
  StageTimer timer(*this, Stage::ColourDiffusion);
  const int nxt = 1 - cur_;
  cl::Kernel& k = kernels_["colour_diffuse"];
  k.setArg(0, sizeof(SimParams), &params_);
  k.setArg(1, pos_[cur_]);
  k.setArg(2, phase_[cur_]);
  k.setArg(3, density_);
  k.setArg(4, colour_[cur_]);
  k.setArg(5, snbr_);
  k.setArg(6, snbr_count_);
  k.setArg(7, colour_[nxt]);
  kernels_.enqueue("colour_diffuse", n_, kLocal);
  // The other fields are not double-buffered past this point: copy the new colours back.
  clCall("copying colours", [&] { return cl_.queue().enqueueCopyBuffer(colour_[nxt], colour_[cur_], 0, 0, n_ * 16); });
}

void Simulation::integrate() {
  StageTimer timer(*this, Stage::Integrate);
  cl::Kernel& k = kernels_["integrate"];
  k.setArg(0, sizeof(SimParams), &params_);
  k.setArg(1, pos_[cur_]);
  k.setArg(2, vel_[cur_]);
  k.setArg(3, acc_);
  k.setArg(4, crossings_);
  k.setArg(5, max_speed_);
  kernels_.enqueue("integrate", n_, kLocal);
  // The step's largest speed bounds every displacement: the lists stay valid while the sum of
  // max speed * dt since they were built is below skin / 2.
  uint32_t bits = 0;
  const uint32_t zero = 0;
  clCall("reading the step's largest speed", [&] {
    cl_.queue().enqueueReadBuffer(max_speed_, CL_TRUE, 0, 4, &bits);
    cl_.queue().enqueueWriteBuffer(max_speed_, CL_TRUE, 0, 4, &zero);
    return 0;
  });
  float vmax;
  std::memcpy(&vmax, &bits, 4);
  travel_since_build_ += std::isfinite(vmax) ? vmax * params_.dt : INFINITY;
}

FrameReport Simulation::runDiagnostics() {
  StageTimer timer(*this, Stage::Diagnostics);
  FrameReport rep;
  params_.n_fluid = static_cast<sph_uint>(n_);
  const uint32_t chunk = static_cast<uint32_t>((n_ + diag_groups_ - 1) / diag_groups_);
  std::vector<uint32_t> out(diag_groups_ * 8, 0);
  uint32_t crossings = 0, overflow = 0;
  if (n_ > 0) {
    cl::Kernel& k = kernels_["diagnostics"];
    k.setArg(0, sizeof(SimParams), &params_);
    k.setArg(1, chunk);
    k.setArg(2, pos_[cur_]);
    k.setArg(3, vel_[cur_]);
    k.setArg(4, density_);
    k.setArg(5, diag_);
    kernels_.enqueue("diagnostics", diag_groups_);
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
  // Before the first step there is no grid yet: build it (the first step then finds it valid and
  // produces the same state as without this call, as long as no inflow emits at t = 0).
  params_.n_fluid = static_cast<sph_uint>(n_);
  if (!lists_valid_ && n_ > 0) buildGrid();
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
  return h;
}

}  // namespace sph
