// DFSPH two-level solve, host side: the coarse-grid correction of kernels/dfsph_coarse.cl (which
// derives it). The device writes each particle's residual, aggregate cell and per-aggregate pair
// sums F, R; here the aggregates are numbered in particle order, the Galerkin operator
// K_dc = dt^2 V0 sum_i F_i(c) . R_i(d) and the right-hand side P^T r are summed in particle order
// (double), K e = P^T r is solved by sparse LU (a fixed sequence of operations), and the prolonged
// correction goes back to the device. Everything in a fixed order: bitwise deterministic.
//
// Reuse within a step: assembling K (the pair sums of every particle, read back and summed into a
// 125-point stencil) and its LU cost more than the rest of a correction. Positions, densities and
// walls do not change during a step's solves, so a solve's later corrections (after iterations
// 1 + k, 1 + 2k, ...) use the factorization of its first, as long as the active particles still
// lie in its aggregates (up to kCoarseMissShare of them may lie in aggregates it lacks: they take
// no correction) and its last line search stayed within [kCoarseThetaLow, kCoarseThetaHigh]. K
// scales with dt^2, so a change of step would be exact (e = (dt_K / dt)^2 K^-1 P^T r). Kept
// across steps (kCoarseMaxAge > 0; measured on the hydrostatic tank, README "DFSPH"): at the
// scene's artificial viscosity the stale operator turned the tank's period-2 bounce chaotic, so
// the operator is rebuilt each step.

#include "core/dfsph.h"
#include "core/dfsph_coarse.h"

#include "core/errors.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace sph {

namespace {
constexpr std::size_t kLocal = 64;  // work-group size, as dfsph.cpp's
// When a factorized coarse operator is used again (the top of this file): at most kCoarseMaxAge
// steps old (0: within the step), missing at most kCoarseMissShare of the active particles, and
// rebuilt after a line search outside [kCoarseThetaLow, kCoarseThetaHigh]; kCoarseThetaMax bounds
// the line search.
constexpr uint64_t kCoarseMaxAge = 0;                                      // (unit: steps)
constexpr double kCoarseMissShare = 0.02;                                  // (unit: 1)
constexpr double kCoarseThetaLow = 0.75, kCoarseThetaHigh = 1.25;          // (unit: 1)
constexpr double kCoarseThetaMax = 2.0;                                    // (unit: 1)
}

DfsphSolver::~DfsphSolver() = default;

void DfsphSolver::coarseCorrection(Kind kind, const SimParams& p, const DfsphFields& f, cl::Buffer& pressure) {
  const std::size_t n = p.n_fluid;
  if (n == 0) return;
  const bool div = kind == Kind::Divergence;
  const uint32_t min_nbr = div ? min_neighbours_ : 0u;
  // The pressure accelerations of the current pressures (as iterate()'s first pass), then the
  // signed residuals, the active set and the aggregates' pair sums.
  const int use_bp = extrapolated() ? 1 : 0;
  if (use_bp) boundaryPressure(kind, p, f, pressure);
  kernels_.call("dfsph_pressure_accel", n, kLocal, p, xt_, *f.phase, *f.density, pressure, *f.snbr, *f.snbr_count,
                *f.bpos, *f.sbnbr, *f.sbnbr_count, wallFactor(), wallPressure(kind), use_bp, accel_, gwall_);
  kernels_.call("dfsph_coarse_residual", n, kLocal, p, *f.pos, accel_, source_, *f.snbr, *f.snbr_count,
                *f.sbnbr_count, min_nbr, pressure, gwall_, 0, cres_, ccell_);
  hres_.resize(n);
  hcell_.resize(n * 4);
  clCall("reading the DFSPH coarse residual", [&] {
    auto& q = cl_.queue();
    q.enqueueReadBuffer(cres_, CL_FALSE, 0, n * 4, hres_.data());
    return q.enqueueReadBuffer(ccell_, CL_TRUE, 0, n * 16, hcell_.data());
  });

  // The box of aggregate cells (one cell of margin); particles that are not finite or far from
  // the rest (a blown-up run, left to the diagnostics) would make it huge: no correction then.
  std::array<int32_t, 3> lo{INT32_MAX, INT32_MAX, INT32_MAX}, hi{INT32_MIN, INT32_MIN, INT32_MIN};
  for (std::size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      const int32_t c = hcell_[4 * i + a];
      if (c > (1 << 20) || c < -(1 << 20)) return;
      lo[a] = std::min(lo[a], c - 1);
      hi[a] = std::max(hi[a], c + 1);
    }
  const int64_t nx = int64_t(hi[0]) - lo[0] + 1, ny = int64_t(hi[1]) - lo[1] + 1, nz = int64_t(hi[2]) - lo[2] + 1;
  if (nx * ny * nz > int64_t(64) * int64_t(n) + 4096) return;
  std::vector<int32_t> index(static_cast<std::size_t>(nx * ny * nz), -1);
  auto box = [&](int32_t x, int32_t y, int32_t z) {
    return static_cast<std::size_t>(((x - lo[0]) * ny + (y - lo[1])) * nz + (z - lo[2]));
  };
  // Aggregates of fewer than kMinAggregate active particles (slivers at a free surface or a wall,
  // splashes) leave the coarse space: their one-row Galerkin entries are nearly singular and the
  // mirrored wall term of K is far from the extrapolated walls' there (the Jacobi passes keep them).
  constexpr int32_t kMinAggregate = 4;
  for (std::size_t i = 0; i < n; ++i)
    if (hcell_[4 * i + 3]) --index[box(hcell_[4 * i], hcell_[4 * i + 1], hcell_[4 * i + 2])];
  bool dropped = false;
  std::size_t active = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!hcell_[4 * i + 3]) continue;
    if (-index[box(hcell_[4 * i], hcell_[4 * i + 1], hcell_[4 * i + 2])] - 1 < kMinAggregate) {
      hcell_[4 * i + 3] = 0;
      hres_[i] = 0.0f;
      dropped = true;
    } else {
      ++active;
    }
  }
  if (active == 0) return;

  // Keep the factorized operator of the last build while it fits (the top of this file): its
  // aggregates hold all but kCoarseMissShare of the active particles, and it is at most
  // kCoarseMaxAge steps old (0: this step's).
  DfsphCoarseOperator& op = *coarse_op_[div ? 0 : 1];
  std::size_t missed = 0;
  if (op.valid && steps_ - op.step <= kCoarseMaxAge)
    for (std::size_t i = 0; i < n; ++i)
      if (hcell_[4 * i + 3] && op.at(hcell_[4 * i], hcell_[4 * i + 1], hcell_[4 * i + 2]) < 0) ++missed;
  const bool reuse = op.valid && steps_ - op.step <= kCoarseMaxAge && double(missed) <= kCoarseMissShare * double(active);
  if (!reuse) {
    op.valid = false;
    if (dropped)
      clCall("writing the DFSPH aggregates",
             [&] { return cl_.queue().enqueueWriteBuffer(ccell_, CL_TRUE, 0, n * 16, hcell_.data()); });
    // Per particle and aggregate F and R (dfsph_coarse_pairs). Extrapolated walls: a smooth
    // pressure's wall pressure is the fluid's next to it (mirrored, w = 2); single walls w = 1.
    const float wall = extrapolated() ? 2.0f : 1.0f;
    kernels_.call("dfsph_coarse_pairs", n, kLocal, p, *f.pos, *f.phase, *f.density, *f.snbr, *f.snbr_count, gwall_,
                  ccell_, wall, cfr_);
    hfr_.resize(n * 27 * 2 * 4);
    clCall("reading the DFSPH coarse terms",
           [&] { return cl_.queue().enqueueReadBuffer(cfr_, CL_TRUE, 0, n * 27 * 2 * 16, hfr_.data()); });

    // Number the aggregates (cells with an active particle) in particle order.
    std::fill(index.begin(), index.end(), -1);
    int32_t m = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!hcell_[4 * i + 3]) continue;
      int32_t& k = index[box(hcell_[4 * i], hcell_[4 * i + 1], hcell_[4 * i + 2])];
      if (k < 0) k = m++;
    }

    // K_dc = dt^2 V0 sum_i F_i(c) . R_i(d), summed in particle order into a 5 x 5 x 5 stencil per
    // aggregate (c and d lie within one cell of i's: their offset within two).
    std::vector<double> stencil(static_cast<std::size_t>(m) * 125, 0.0);
    const double scale = double(p.dt) * double(p.dt) * double(p.rest_volume);
    // Per particle only the slots with an aggregate and a non-zero F (columns) or R (rows) take
    // part (~8 of 27); they are visited in slot order, so each entry's sum keeps its order.
    std::array<int32_t, 27> slot_index;
    std::array<int, 27> rows, cols;
    for (std::size_t i = 0; i < n; ++i) {
      const int32_t cx = hcell_[4 * i], cy = hcell_[4 * i + 1], cz = hcell_[4 * i + 2];
      const float* fr = hfr_.data() + i * 27 * 2 * 4;
      int nr = 0, nc = 0;
      for (int s = 0; s < 27; ++s) {
        slot_index[s] = index[box(cx + s / 9 - 1, cy + (s / 3) % 3 - 1, cz + s % 3 - 1)];
        if (slot_index[s] < 0) continue;
        const float* F = fr + 2 * s * 4;
        const float* R = F + 4;
        if (R[0] != 0.0f || R[1] != 0.0f || R[2] != 0.0f) rows[nr++] = s;
        if (F[0] != 0.0f || F[1] != 0.0f || F[2] != 0.0f) cols[nc++] = s;
      }
      for (int a = 0; a < nr; ++a) {
        const int sd = rows[a];
        const float* R = fr + (2 * sd + 1) * 4;
        double* row = stencil.data() + static_cast<std::size_t>(slot_index[sd]) * 125;
        for (int b = 0; b < nc; ++b) {
          const int sc = cols[b];
          const float* F = fr + 2 * sc * 4;
          const double v = double(F[0]) * R[0] + double(F[1]) * R[1] + double(F[2]) * R[2];
          if (v == 0.0) continue;
          const int o = (sc / 9 - sd / 9 + 2) * 25 + ((sc / 3) % 3 - (sd / 3) % 3 + 2) * 5 + (sc % 3 - sd % 3 + 2);
          row[o] += scale * v;
        }
      }
    }
    // The aggregates' cells, for the stencil's columns.
    std::vector<std::array<int32_t, 3>> cells(static_cast<std::size_t>(m));
    for (int32_t x = lo[0]; x <= hi[0]; ++x)
      for (int32_t y = lo[1]; y <= hi[1]; ++y)
        for (int32_t z = lo[2]; z <= hi[2]; ++z)
          if (const int32_t k = index[box(x, y, z)]; k >= 0) cells[static_cast<std::size_t>(k)] = {x, y, z};
    std::vector<Eigen::Triplet<double>> entries;
    entries.reserve(static_cast<std::size_t>(m) * 27);
    for (int32_t d = 0; d < m; ++d) {
      const auto& c = cells[static_cast<std::size_t>(d)];
      for (int o = 0; o < 125; ++o) {
        const double v = stencil[static_cast<std::size_t>(d) * 125 + static_cast<std::size_t>(o)];
        if (v == 0.0) continue;
        const int32_t x = c[0] + o / 25 - 2, y = c[1] + (o / 5) % 5 - 2, z = c[2] + o % 5 - 2;
        if (x < lo[0] || x > hi[0] || y < lo[1] || y > hi[1] || z < lo[2] || z > hi[2]) continue;
        const int32_t col = index[box(x, y, z)];
        if (col >= 0) entries.emplace_back(d, col, v);
      }
    }
    Eigen::SparseMatrix<double> K(m, m);
    K.setFromTriplets(entries.begin(), entries.end());
    K.makeCompressed();

    // Factorize K (COLAMD ordering; AMD took 2.7x as long on the slab dam break); a singular or
    // failed factorization (a closed fluid without free surface has the constant pressure in K's
    // null space) leaves the pressures as they are.
    op.lu.compute(K);
    if (op.lu.info() != Eigen::Success) return;
    op.valid = true;
    op.lo = lo;
    op.hi = hi;
    op.ny = ny;
    op.nz = nz;
    op.index = std::move(index);
    op.m = m;
    op.dt2 = double(p.dt) * double(p.dt);
    op.step = steps_;
  }

  // P^T r on the operator's aggregates, in particle order (the active particles outside them take
  // no correction).
  Eigen::VectorXd b = Eigen::VectorXd::Zero(op.m);
  for (std::size_t i = 0; i < n; ++i) {
    if (!hcell_[4 * i + 3]) continue;
    const int32_t k = op.at(hcell_[4 * i], hcell_[4 * i + 1], hcell_[4 * i + 2]);
    if (k < 0) {
      hcell_[4 * i + 3] = 0;
      hres_[i] = 0.0f;
      continue;
    }
    b[k] += hres_[i];
  }
  // Solve K e = P^T r (K of dt_K scaled to this step's dt: K ~ dt^2).
  Eigen::VectorXd e = op.lu.solve(b);
  if (op.lu.info() != Eigen::Success || !e.allFinite()) {
    op.valid = false;
    return;
  }
  e *= op.dt2 / (double(p.dt) * double(p.dt));

  // Prolong (piecewise constant, active particles only) and project: p_i <- max(p_i + e_c(i), 0).
  hdp_.assign(n, 0.0f);
  for (std::size_t i = 0; i < n; ++i)
    if (hcell_[4 * i + 3]) hdp_[i] = static_cast<float>(e[op.at(hcell_[4 * i], hcell_[4 * i + 1], hcell_[4 * i + 2])]);
  clCall("writing the DFSPH coarse correction",
         [&] { return cl_.queue().enqueueWriteBuffer(cdp_, CL_TRUE, 0, n * 4, hdp_.data()); });
  // Line search: the step theta along q = P e that makes the correction Galerkin-exact for the
  // walls' own operator (K's mirrored wall term is an approximation, and the wall pressure is
  // projected to >= 0): with dr the change of the residual that q actually makes (the trial
  // pressures max(p + q, 0), their extrapolated wall pressure, accelerations and residual),
  // theta = -<q, r> / <q, dr> over the active particles, within [0, kCoarseThetaMax].
  kernels_.call("dfsph_coarse_trial", n, kLocal, p, *f.pos, *f.phase, *f.density, cdp_, pressure, ctrial_, xt_);
  if (use_bp) boundaryPressure(kind, p, f, ctrial_);
  kernels_.call("dfsph_pressure_accel", n, kLocal, p, xt_, *f.phase, *f.density, ctrial_, *f.snbr, *f.snbr_count,
                *f.bpos, *f.sbnbr, *f.sbnbr_count, wallFactor(), wallPressure(kind), use_bp, accel_, gwall_);
  kernels_.call("dfsph_coarse_residual", n, kLocal, p, *f.pos, accel_, source_, *f.snbr, *f.snbr_count,
                *f.sbnbr_count, min_nbr, ctrial_, gwall_, 1, cres_, ccell_);
  hmq_.resize(n);
  clCall("reading the DFSPH line search",
         [&] { return cl_.queue().enqueueReadBuffer(cres_, CL_TRUE, 0, n * 4, hmq_.data()); });
  for (std::size_t i = 0; i < n; ++i) hmq_[i] -= hres_[i];  // dr (active particles; the others unused)
  double qr = 0.0, qMq = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!hcell_[4 * i + 3]) continue;
    qr += double(hdp_[i]) * hres_[i];
    qMq += double(hdp_[i]) * hmq_[i];  // <q, dr>
  }
  const double theta = qMq < 0.0 ? std::clamp(-qr / qMq, 0.0, kCoarseThetaMax) : 0.0;
  // A reused operator that the walls' own operator scales far from 1 no longer fits: rebuild next time.
  if (reuse && (theta < kCoarseThetaLow || theta > kCoarseThetaHigh)) op.valid = false;
  for (float& v : hdp_) v = static_cast<float>(theta * v);
  clCall("writing the DFSPH coarse correction",
         [&] { return cl_.queue().enqueueWriteBuffer(cdp_, CL_TRUE, 0, n * 4, hdp_.data()); });
  kernels_.call("dfsph_coarse_apply", n, kLocal, p, *f.pos, *f.phase, *f.density, cdp_, pressure, xt_);
}

}  // namespace sph
