/* Divergence-free SPH (stages: divergence_solve, density_solve; solver dfsph only).
 *
 * Bender & Koschier 2017, "Divergence-Free SPH for Incompressible and Viscous Fluids" (IEEE TVCG),
 * Alg. 1-3, written here for the symmetric multi-fluid pressure force that the WCSPH path uses
 * (Solenthaler & Pajarola 2008 eq. 6, pressure.cl), with number densities delta = rho / m, so that
 * phases of different rest densities share one target, delta0 = 1 / V0 (V0 = dx^3):
 *     a_i^p = -(1/m_i) [ sum_j (p_i/delta_i^2 + p_j/delta_j^2) gradW_ij + sum_b psi_b w p_i/delta_i^2 gradW_ib ]
 * Boundary particles b (psi_b = V_b / V0, Akinci et al. 2012) weigh p_i / delta_i^2 by w = `wall`
 * (fluid.dfsph.walls): mirrored, w = 2 (p_b = p_i in the symmetric term), so a wall holds the
 * column at the fluid's spacing; single, w = 1 (Akinci's term, the reference implementation's).
 *
 * The factor (B&K 2017 eq. 8-9): the pressure p_i alone, acting on i and, equal and opposite, on
 * its neighbours over one step dt, changes delta_i by
 *     Delta delta_i = -dt^2 p_i / delta_i^2 D_i,
 *     D_i = (1/m_i) (G_f + w G_b) . (G_f + G_b) + sum_j |gradW_ij|^2 / m_j,
 *     G_f = sum_j gradW_ij,   G_b = sum_b psi_b gradW_ib,
 * so alpha_i = delta_i^2 / D_i (unit: kg m^2) turns a number-density defect into a pressure:
 *     density solve (B&K eq. 12):    p_i = (delta*_i - delta0) alpha_i / dt^2,
 *     divergence solve (B&K eq. 15): p_i = (D delta_i / Dt) alpha_i / dt,
 * with delta*_i = delta_i + dt D delta_i / Dt the density predicted from the current velocities and
 *     D delta_i / Dt = sum_j (v_i - v_j) . gradW_ij + sum_b psi_b (v_i - v_b) . gradW_ib   (B&K eq. 2).
 * Two iterations, by the walls (fluid.dfsph.walls):
 *
 * single (w = 1; the reference implementation SPlisHSPlasH's formulation since 2.x): B&K 2017
 * Alg. 2-3 as a linear complementarity problem, relaxed Jacobi on the pressures projected to
 * p >= 0. The source s_i is computed once from the velocities the solve starts with (relative
 * units: density solve s_i = delta*_i V0 - 1, divergence solve s_i = dt V0 D delta_i / Dt), then
 * each iteration
 *     a_i = a_i^p(p)                                   (dfsph_pressure_accel, the force above / m_i)
 *     r_i = s_i + dt^2 V0 [ sum_j (a_i - a_j) . gradW_ij + sum_b psi_b a_i . gradW_ib ]   (= s - A p)
 *     p_i <- max(p_i + omega r_i alpha_i / (dt^2 V0), 0)                                  (dfsph_jacobi)
 * with the error the compression left, err_i = max(r_i, 0) (extrapolated walls: the residual of the
 * complementarity problem, |r_i| where p_i > 0, max(r_i, 0) where p_i = 0, so that an overshoot
 * of the pressure counts too); after the last iteration the velocities
 * take the pressure once, v_i += dt a_i^p(p) (dfsph_apply_pressure). A is symmetric and a pressure
 * that overshot comes back down in the next iteration. The pressure is kept for the next step's
 * warm start, all of it (dfsph_source).
 *
 * mirrored (w = 2): A is not symmetric (p_i acts on i through the wall twice, while i's own
 * density sees the wall once); the projected iteration above diverged there (the hydrostatic tank
 * boiled at rest with every diagonal tried). It keeps the first version's iteration: one pass
 * computes increments from the current velocities (dfsph_divergence_source, dfsph_density_source),
 * each >= 0, the next applies them to the velocities (dfsph_apply_increments); stable, but an
 * overshoot stays for the rest of the step. Warm start: half the last pressure (dfsph_warm).
 *
 * extrapolated (w = 1 and the wall's own pressure p_b in the symmetric sum, as WCSPH's walls,
 * pressure.cl): p_b = (sum_f p_f W_bf + g . sum_f rho_f r_bf W_bf) / sum_f W_bf (Adami, Hu & Adams
 * 2012 eq. 27; the hydrostatic term in the density solve only) from the current pressures, before
 * each iteration's accelerations (pressure.cl boundary_pressure), as Band et al. 2018 do for IISPH:
 *     a_i^p += -(1/m_i) sum_b psi_b p_b / delta_i^2 gradW_ib.
 * The constant pressure of a fluid at a wall then exerts no net force on it, and the layer next to
 * a floor reads rho0 g (H - z) (single walls: ~1.7x). The factor keeps w = 1 (p_b's share of p_i
 * is left off the diagonal; w = 1.5 or 2 there were worse). The projected Jacobi iteration of
 * single, with the full last pressure as warm start everywhere (the projection lowers it where it
 * must) and the complementarity residual as error (|r_i| where p_i > 0, so that an overshoot
 * counts: with the one-sided error and full warm start the pressures ratcheted up 89 %). A
 * particle the divergence solve skips (too few neighbours) keeps that warm start only while its
 * neighbours close in (dfsph_source), and the particles the solve leaves at p = 0 at a wall get a
 * contact force (dfsph_wall_contact_accel, in dfsph_predict) and, at the closed domain walls, a
 * non-penetration contact after the density solve (dfsph_wall_impulse: layers one particle thick).
 *
 * Neighbours: this step's lists within H (snbr, sbnbr; density.cl). */

/* Performance: walls and bodies do not move during a step's solves, so the factor pass keeps each
 * particle's wall sums gwall_i = (G_b, sum_b psi_b v_b . gradW_ib), G_b = sum_b psi_b gradW_ib,
 * and the later passes use them instead of a loop over the wall neighbours:
 *     sum_b psi_b (v_i - v_b) . gradW_ib = v_i . G_b - gwall_i.w     (density rate),
 *     sum_b psi_b a_i . gradW_ib = a_i . G_b                         (Jacobi residual),
 *     sum_b psi_b w t_i gradW_ib = w t_i G_b                          (pressure force). */

/* sum_b psi_b gradW_ib over a boundary list (xyz) and sum_b psi_b q_b . gradW_ib (w) with
 * q_b = vel[b] (when `vel` is not null), or with the scalars s[b] (when `s` is not null):
 * sum_b psi_b s_b gradW_ib in xyz instead. Eight at a time (shared/pair_loops.h), lanes summed in
 * a fixed order, then the rest one by one. */
SPH_HOT float4 dfsph_wall_sums(const float3 xi, __global const uint* list, const uint nb, __global const float4* bpos,
                               __global const float4* bvel, __global const float* s, const float H) {
  float8 gx = (float8)(0.0f), gy = gx, gz = gx, fl = gx;
  uint k = 0;
  for (; k + 8 <= nb; k += 8) {
    const uint8 b = vload8(0, list + k);
    SPH_LOAD8(x, bpos, b);
    const float8 dx = xi.x - SPH_LANES8(x, x), dy = xi.y - SPH_LANES8(x, y), dz = xi.z - SPH_LANES8(x, z);
    float8 F = SPH_LANES8(x, w) * sph_grad_factor8(sqrt(dx * dx + dy * dy + dz * dz), H);
    if (s) F *= SPH_GATHER8(s, b);
    gx += F * dx;
    gy += F * dy;
    gz += F * dz;
    if (bvel) {
      SPH_LOAD8(v, bvel, b);
      fl += F * (SPH_LANES8(v, x) * dx + SPH_LANES8(v, y) * dy + SPH_LANES8(v, z) * dz);
    }
  }
  float4 r = (float4)(sph_hsum8(gx), sph_hsum8(gy), sph_hsum8(gz), sph_hsum8(fl));
  for (; k < nb; ++k) {
    const uint b = list[k];
    const float4 bb = bpos[b];
    const float3 d = xi - bb.xyz;
    float F = bb.w * sph_grad_factor(SPH_KERNEL, length(d), H);
    if (s) F *= s[b];
    r.xyz += F * d;
    if (bvel) r.w += F * dot(bvel[b].xyz, d);
  }
  return r;
}

/* M v for a symmetric 3 x 3 stored as rows m[3s], m[3s+1], m[3s+2] (the cloth nodes' M^-1 below) */
inline float3 dfsph_mul3(__global const float4* m, const uint s, const float3 v) {
  return (float3)(dot(m[3 * s].xyz, v), dot(m[3 * s + 1].xyz, v), dot(m[3 * s + 2].xyz, v));
}

/* sum_b psi_b a_b . gradW_ib over a boundary list, a_b the cloth nodes' accelerations in the solves
 * (dfsph_node_accel; w = 0 for the rest of the boundary, skipped) */
inline float dfsph_node_sum(const float3 xi, __global const uint* list, const uint nb, __global const float4* bpos,
                            __global const float4* bacc, const float H) {
  float sum = 0.0f;
  for (uint q = 0; q < nb; ++q) {
    const uint b = list[q];
    const float4 ab = bacc[b];
    if (ab.w == 0.0f) continue;
    const float4 bb = bpos[b];
    const float3 d = xi - bb.xyz;
    sum += bb.w * sph_grad_factor(SPH_KERNEL, length(d), H) * dot(ab.xyz, d);
  }
  return sum;
}

/* Factor alpha_i = delta_i^2 / D_i (B&K 2017 eq. 9, for the pressure force above), and the wall
 * sums gwall_i (above). With `with_rate` also the divergence solve's density rate D delta_i / Dt
 * (B&K 2017 eq. 2) of the velocities `vel` into rate_out, from the same pairs: one neighbour pass
 * fewer per step (performance; dfsph_source reads it). */
SPH_PSABI_QUIET
__kernel void dfsph_factor(const SimParams p, __global const float4* pos, __global const uint* phase,
                           __global float* density, __global const uint* nbr, __global const uint* nbr_count,
                           __global const float4* bpos, __global const uint* bnbr,
                           __global const uint* bnbr_count, const float wall, __global float* alpha,
                           __global const float4* bvel, __global float4* gwall, const int with_rate,
                           __global const float4* vel, __global float* rate_out, const int one_mass,
                           const int nodes, __global const float4* bminv, const int with_density,
                           __global float* pressure, __global float* pterm, const uint stamp, __global uint* bmark) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float H = p.support;
  const float3 xi = pos[i].xyz;
  const float3 vi = vel[i].xyz;
  const float mi = p.phase_mass[phase[i]];
  const SphList list = sph_list(&p, nbr, i); /* narrow or wide (shared/neighbours.h) */
  /* sums of gradients over fluid and boundary, and sum_j |gradW_ij|^2 / m_j; fluid pairs eight at
   * a time (shared/pair_loops.h), lanes summed in a fixed order, then the rest one by one */
  float8 sx = (float8)(0.0f), sy = sx, sz = sx, s8 = sx, r8 = sx, w8 = sx;
  const uint nf = nbr_count[i];
  uint k = 0;
  /* sixteen at a time first, each sum taking the two halves in turn: the eight-wide loop's operations
   * in its order, so bitwise its sums (performance; as dfsph_force) */
#if SPH_PAIR16
  for (; k + 16 <= nf; k += 16) {
    const uint16 j = sph_list16(list, k);
    SPH_LOAD16(x, pos, j);
    const float16 dx = xi.x - x_x, dy = xi.y - x_y, dz = xi.z - x_z;
    const float16 r2 = dx * dx + dy * dy + dz * dz;
    SPH_GRAD_FACTOR16(F, sqrt(r2), H);
    if (with_density) {
      SPH_W16(w, sqrt(r2), H);
      w8 += w.lo;
      w8 += w.hi;
    }
    const float16 ax = F * dx, ay = F * dy, az = F * dz;
    sx += ax.lo;
    sy += ay.lo;
    sz += az.lo;
    sx += ax.hi;
    sy += ay.hi;
    sz += az.hi;
    if (one_mass) {
      const float16 t = (ax * ax + ay * ay + az * az) / mi;
      s8 += t.lo;
      s8 += t.hi;
    } else {
      const uint16 phj = (uint16)(phase[j.s0], phase[j.s1], phase[j.s2], phase[j.s3], phase[j.s4], phase[j.s5],
                                  phase[j.s6], phase[j.s7], phase[j.s8], phase[j.s9], phase[j.sa], phase[j.sb],
                                  phase[j.sc], phase[j.sd], phase[j.se], phase[j.sf]);
      const float16 t = (ax * ax + ay * ay + az * az) /
                        (float16)(p.phase_mass[phj.s0], p.phase_mass[phj.s1], p.phase_mass[phj.s2],
                                  p.phase_mass[phj.s3], p.phase_mass[phj.s4], p.phase_mass[phj.s5],
                                  p.phase_mass[phj.s6], p.phase_mass[phj.s7], p.phase_mass[phj.s8],
                                  p.phase_mass[phj.s9], p.phase_mass[phj.sa], p.phase_mass[phj.sb],
                                  p.phase_mass[phj.sc], p.phase_mass[phj.sd], p.phase_mass[phj.se],
                                  p.phase_mass[phj.sf]);
      s8 += t.lo;
      s8 += t.hi;
    }
    if (with_rate) {
      SPH_LOAD16(v, vel, j);
      const float16 u = (vi.x - v_x) * dx + (vi.y - v_y) * dy + (vi.z - v_z) * dz;
      r8 += F.lo * u.lo;
      r8 += F.hi * u.hi;
    }
  }
#endif
  for (; k + 8 <= nf; k += 8) {
    const uint8 j = sph_list8(list, k);
    SPH_LOAD8(x, pos, j);
    const float8 dx = xi.x - SPH_LANES8(x, x), dy = xi.y - SPH_LANES8(x, y), dz = xi.z - SPH_LANES8(x, z);
    const float8 r2 = dx * dx + dy * dy + dz * dz;
    const float8 F = sph_grad_factor8(sqrt(r2), H);
    /* with_density: the number density's fluid sum, as sph_list_density (the same r, order and arithmetic) */
    if (with_density) w8 += sph_w8(sqrt(r2), H);
    const float8 ax = F * dx, ay = F * dy, az = F * dz;
    sx += ax;
    sy += ay;
    sz += az;
    /* one_mass: every phase has i's mass (one phase), so no gather of the neighbours' phases */
    if (one_mass) {
      s8 += (ax * ax + ay * ay + az * az) / mi;
    } else {
      const uint8 phj = (uint8)(phase[j.s0], phase[j.s1], phase[j.s2], phase[j.s3], phase[j.s4], phase[j.s5],
                                phase[j.s6], phase[j.s7]);
      s8 += (ax * ax + ay * ay + az * az) / SPH_GATHER8(p.phase_mass, phj);
    }
    /* with_rate: the density rate's pair terms, as dfsph_density_rate */
    if (with_rate) {
      SPH_LOAD8(v, vel, j);
      r8 += F * ((vi.x - SPH_LANES8(v, x)) * dx + (vi.y - SPH_LANES8(v, y)) * dy + (vi.z - SPH_LANES8(v, z)) * dz);
    }
  }
  float3 gf = (float3)(sph_hsum8(sx), sph_hsum8(sy), sph_hsum8(sz));
  float s2 = sph_hsum8(s8);
  float rate = sph_hsum8(r8);
  float wf = sph_hsum8(w8);
  for (; k < nf; ++k) {
    const uint j = sph_list1(list, k);
    const float3 d = xi - pos[j].xyz;
    const float Fk = sph_grad_factor(SPH_KERNEL, length(d), H);
    if (with_density) wf += sph_w(SPH_KERNEL, sqrt(dot(d, d)), H);
    const float3 g = Fk * d;
    gf += g;
    s2 += dot(g, g) / (one_mass ? mi : p.phase_mass[phase[j]]);
    if (with_rate) rate += Fk * dot(vi - vel[j].xyz, d);
  }
  const float4 gw = dfsph_wall_sums(xi, bnbr + (size_t)i * K, bnbr_count[i], bpos, bvel, 0, H);
  gwall[i] = gw;
  /* with_rate: D delta_i / Dt of `vel` (dfsph_density_rate: the same pairs, order and arithmetic,
   * so bitwise its value), for dfsph_source to read instead of its own neighbour loop */
  if (with_rate) rate_out[i] = rate + (dot(vi, gw.xyz) - gw.w);
  const float3 gb = gw.xyz;
  /* nodes (cloth nodes move inside the solves, dfsph_node_accel): p_i moves each node b near i by
   * at most wall t_i psi_b gradW_ib / m_b, which the residual sees as -psi_b a_b . gradW_ib: the
   * diagonal gains wall sum_b psi_b^2 |gradW_ib|^2 / m_b (bminv[3b].w: 1 / m_b per boundary slot, 0
   * for walls, bodies and anchored nodes). A node held by its springs moves less: the bound keeps
   * the relaxed iteration from overshooting (with M^-1 of the springs here, the sandwich test's
   * sheet swung up: its sweeps spread the load, and the response grew past the diagonal's). */
  float sn = 0.0f;
  if (nodes) {
    __global const uint* bl = bnbr + (size_t)i * K;
    const uint nbb = bnbr_count[i];
    for (uint q = 0; q < nbb; ++q) {
      const uint b = bl[q];
      const float iv = bminv[3 * b].w;
      if (iv == 0.0f) continue;
      const float4 bb = bpos[b];
      const float3 d = xi - bb.xyz;
      const float3 g = (bb.w * sph_grad_factor(SPH_KERNEL, length(d), H)) * d;
      sn += dot(g, g) * iv;
    }
  }
  const float D = dot(gf + wall * gb, gf + gb) / mi + s2 + wall * sn;
  /* with_density: this pass is the step's density pass too (compute_density, kernels/density.cl: the
   * same sums in the same order, so bitwise its density, pressure, p / delta^2 and boundary marks), one
   * neighbour pass fewer per step where the lists are this step's (core/simulation.cpp, computeDensity) */
  float rho;
  if (with_density) {
    uint sb = 0;
    float nd = sph_w(SPH_KERNEL, 0.0f, H);
    nd += wf;
    nd += sph_list_density(xi, bnbr, i, K, 1, bnbr_count[i], bpos, 1, H, 0, 0, &sb);
    const uint nb = bnbr_count[i];
    for (uint q = 0; q < nb; ++q) bmark[bnbr[(size_t)i * K + q]] = stamp;
    rho = sph_density_state(&p, phase[i], nd, pressure, pterm, i);
    density[i] = rho;
  } else {
    rho = density[i];
  }
  const float delta = rho / mi;
  /* a particle without neighbours takes no pressure */
  alpha[i] = D > 0.0f ? delta * delta / D : 0.0f;
}
SPH_PSABI_LOUD

/* D delta_i / Dt (B&K 2017 eq. 2, number density): the rate at which the neighbours close in; the
 * walls' part from the factor pass's sums gw (v_i . G_b - sum_b psi_b v_b . gradW_ib). */
SPH_PSABI_QUIET
SPH_HOT float dfsph_density_rate(const SimParams* p, const uint i, __global const float4* pos,
                                 __global const float4* vel, __global const uint* lists, const uint nf,
                                 const float4 gw) {
  const float H = p->support;
  const float3 xi = pos[i].xyz, vi = vel[i].xyz;
  const SphList nbr = sph_list(p, lists, i); /* made here, not passed in by value (as dfsph_force) */
  /* fluid neighbours eight at a time (shared/pair_loops.h: pocl leaves such loops scalar), the
   * lanes summed in a fixed order, then the rest one by one */
  float8 acc = (float8)(0.0f);
  uint k = 0;
  /* sixteen at a time first, the halves added in turn: bitwise the eight-wide loop's sum (as dfsph_force) */
#if SPH_PAIR16
  for (; k + 16 <= nf; k += 16) {
    const uint16 j = sph_list16(nbr, k);
    SPH_LOAD16(x, pos, j);
    SPH_LOAD16(v, vel, j);
    const float16 dx = xi.x - x_x, dy = xi.y - x_y, dz = xi.z - x_z;
    SPH_GRAD_FACTOR16(F, sqrt(dx * dx + dy * dy + dz * dz), H);
    const float16 u = (vi.x - v_x) * dx + (vi.y - v_y) * dy + (vi.z - v_z) * dz;
    acc += F.lo * u.lo;
    acc += F.hi * u.hi;
  }
#endif
  for (; k + 8 <= nf; k += 8) {
    const uint8 j = sph_list8(nbr, k);
    SPH_LOAD8(x, pos, j);
    SPH_LOAD8(v, vel, j);
    const float8 dx = xi.x - SPH_LANES8(x, x), dy = xi.y - SPH_LANES8(x, y), dz = xi.z - SPH_LANES8(x, z);
    const float8 F = sph_grad_factor8(sqrt(dx * dx + dy * dy + dz * dz), H);
    acc += F * ((vi.x - SPH_LANES8(v, x)) * dx + (vi.y - SPH_LANES8(v, y)) * dy + (vi.z - SPH_LANES8(v, z)) * dz);
  }
  float rate = sph_hsum8(acc);
  for (; k < nf; ++k) {
    const uint j = sph_list1(nbr, k);
    const float3 d = xi - pos[j].xyz;
    rate += sph_grad_factor(SPH_KERNEL, length(d), H) * dot(vi - vel[j].xyz, d);
  }
  return rate + (dot(vi, gw.xyz) - gw.w);
}
SPH_PSABI_LOUD

/* The density solve's source s_i = (delta_i + dt D delta_i / Dt) V0 - 1 (B&K 2017 eq. 12), and a solve's
 * starting pressure p0 with xt_i = (x_i, p0 / delta_i^2): shared by dfsph_source and by dfsph_warm_pack and
 * dfsph_source_accel below, which must give its bits. */
inline float dfsph_compression(const SimParams* p, const float delta, const float rate) {
  return (delta + p->dt * rate) * p->rest_volume - 1.0f;
}
inline void dfsph_start_pressure(const uint i, const float p0, const float delta, __global const float4* pos,
                                 __global float* pressure, __global float4* xt) {
  pressure[i] = p0;
  xt[i] = (float4)(pos[i].xyz, p0 / (delta * delta)); /* position and p / delta^2 (dfsph_force) */
}

/* Source of a solve and its warm start (B&K 2017 Alg. 2-3; section 4.4 for the warm start).
 * density (kind 1, eq. 12): s_i = (delta_i + dt D delta_i / Dt) V0 - 1, the relative compression
 *     the current velocities would leave at the end of the step;
 * divergence (kind 0, eq. 15): s_i = dt V0 D delta_i / Dt, the relative density change over dt.
 * The pressure starts from warm x the previous step's where the flow now compresses (everywhere
 * with warm_all: extrapolated walls, whose projected iteration lowers it again where it must), in
 * Pa as it was (not rescaled with dt: a resting column's pressure does not depend on the step),
 * else from zero (warm = 0: no warm start). */
__kernel void dfsph_source(const SimParams p, __global const float4* pos, __global const float4* vel,
                           __global const uint* phase, __global const float* density, __global const uint* nbr,
                           __global const uint* nbr_count, __global const float4* bpos,
                           __global const float4* bvel, __global const uint* bnbr,
                           __global const uint* bnbr_count, const int kind, const uint min_neighbours,
                           const float warm, const int warm_all, __global float* source, __global float* pressure,
                           __global float4* xt, __global const float4* gwall, const int rate_in_source) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  /* rate_in_source: the factor pass left D delta_i / Dt in source[i] (dfsph_factor, with_rate) */
  const float rate = rate_in_source ? source[i]
                                    : dfsph_density_rate(&p, i, pos, vel, nbr, nbr_count[i], gwall[i]);
  const float delta = density[i] / p.phase_mass[phase[i]];
  float s = kind ? dfsph_compression(&p, delta, rate) : p.dt * rate * p.rest_volume;
  /* divergence solve: fewer than min_neighbours neighbours (free surface, splashes): left alone */
  const bool few = nbr_count[i] + bnbr_count[i] < min_neighbours;
  if (few) s = 0.0f;
  source[i] = s;
  /* such a particle keeps its warm start (warm_all) only while its neighbours close in (rate > 0:
   * the reference's rule), not always: dfsph_jacobi skips it, so the pressure would stay. With
   * warm_all a splash kept the pressure it had at an impact (~20 kPa) for as long as it flew, and
   * that pressure, over its few neighbours and the walls it extrapolated to, shot it off at 10-11
   * m/s (the 50k dam break's "jet"). Zeroing it always (the reference) made the hydrostatic tank's
   * top layer, at the threshold, flicker: 109 Pa between frames against 66 Pa. */
  const bool keep = few ? (warm_all && rate > 0.0f) : (s > 0.0f || warm_all);
  dfsph_start_pressure(i, keep ? warm * pressure[i] : 0.0f, delta, pos, pressure, xt);
}

/* Filtered warm start of the density solve (fluid.dfsph.warm_smoothing = beta > 0; session 28):
 *     p_i <- max(p_i + beta sum_j W_ij (p_j - p_i - rho_ij g . (x_j - x_i)) / sum_j W_ij, 0),
 * j over i's fluid neighbours of i's own phase and i itself (W(0), a zero term; across an interface
 * the mean density below would not give the hydrostatic jump), rho_ij = (rho0_i + rho0_j) / 2. It is a Shepard average (a partition of unity: constants kept exactly) of
 * the last pressure minus its hydrostatic part rho0 g . x, which is added back: a resting column's
 * pressure rho0 g (H - z) passes unchanged, in the bulk, at walls and at the surface alike, and so
 * does the smooth part of any pressure. What it takes out is the particle-scale part: the pressure
 * a step left at one particle and not its neighbours, where the lattice has moved since. Restarted
 * from in full, that part pushes each particle with the last step's error, a step late, and a calm
 * tub with little viscosity kept moving (6 cm of water at rest: fastest particle 0.06-0.08 m/s and
 * 15 density iterations per step over 2 s, against 0.01-0.02 m/s and 2 with beta = 0.5). The same
 * part also holds something near close walls, most likely the lattice against the pressure's own
 * particle-scale modes, which the step integrates explicitly: with beta = 0.5 a tank 6 cm wide and
 * 20 cm deep swings at rest at 3.33 ms steps (calm at 2 ms, and calm 16 cm wide), and a 28 cm deep
 * tank with a sinking ball blew up (docs/dfsph.md, session 28). With the warm start averaged over two
 * steps first (dfsph_warm_average, warm_average 0.5) both stay stable (session 29). Off by default:
 * at tight density bounds the pair costs iterations. Reads the neighbours' pressures, writes `out`
 * (not `pressure`). */
__kernel void dfsph_warm_filter(const SimParams p, __global const float4* pos, __global const uint* phase,
                                __global const uint* nbr, __global const uint* nbr_count,
                                __global const float* pressure, const float beta, __global float* out) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float H = p.support;
  const float3 xi = pos[i].xyz;
  const float3 g = (float3)(p.gravity[0], p.gravity[1], p.gravity[2]);
  const float half_inv_v = 0.5f / p.rest_volume; /* rho0 = phase mass / V0 */
  const float ri = p.phase_mass[phase[i]] * half_inv_v;
  const float pi = pressure[i];
  const SphList list = sph_list(&p, nbr, i);
  const uint nf = nbr_count[i];
  /* neighbours eight at a time (shared/pair_loops.h), lanes summed in a fixed order, then the rest */
  float8 sw = (float8)(0.0f), sq = sw;
  uint k = 0;
  for (; k + 8 <= nf; k += 8) {
    const uint8 j = sph_list8(list, k);
    SPH_LOAD8(x, pos, j);
    const float8 dx = SPH_LANES8(x, x) - xi.x, dy = SPH_LANES8(x, y) - xi.y, dz = SPH_LANES8(x, z) - xi.z;
    const float8 w = sph_w8(sqrt(dx * dx + dy * dy + dz * dz), H);
    const float8 rj = (float8)(p.phase_mass[phase[j.s0]], p.phase_mass[phase[j.s1]], p.phase_mass[phase[j.s2]],
                               p.phase_mass[phase[j.s3]], p.phase_mass[phase[j.s4]], p.phase_mass[phase[j.s5]],
                               p.phase_mass[phase[j.s6]], p.phase_mass[phase[j.s7]]) * half_inv_v;
    const float8 ws = select((float8)(0.0f), w, isequal(rj, (float8)(ri)));
    sw += ws;
    sq += ws * (SPH_GATHER8(pressure, j) - pi - (ri + rj) * (g.x * dx + g.y * dy + g.z * dz));
  }
  float wsum = sph_hsum8(sw) + sph_w(SPH_KERNEL, 0.0f, H), qsum = sph_hsum8(sq);
  for (; k < nf; ++k) {
    const uint j = sph_list1(list, k);
    const float3 d = pos[j].xyz - xi;
    const float rj = p.phase_mass[phase[j]] * half_inv_v;
    const float w = rj == ri ? sph_w(SPH_KERNEL, length(d), H) : 0.0f;
    wsum += w;
    qsum += w * (pressure[j] - pi - (ri + rj) * dot(g, d));
  }
  out[i] = fmax(pi + beta * qsum / wsum, 0.0f);
}

/* The fluid part of the pressure force of the top of this file on particle i at xi (unit: N), with
 * t_i = p_i / delta_i^2 = ti, over i's list of nf neighbours, whose positions and p_j / delta_j^2 come
 * packed in xt (dfsph_force):  - sum_j (t_i + t_j) F_ij x_ij.
 * Sixteen neighbours at a time (shared/pair_loops.h, SPH_LOAD16), their terms added to the eight-wide
 * sums a half at a time: the same operations in the same order as eight at a time, so bitwise the
 * same sums (performance: docs/dfsph.md, session 52); then eight at a time, then the rest one by one,
 * the lanes summed in a fixed order. Shared by dfsph_force and dfsph_apply_increments; inlined by
 * force (SPH_HOT). */
SPH_PSABI_QUIET
SPH_HOT float3 dfsph_fluid_pressure_force(const SimParams* p, const float3 xi, const float ti,
                                          __global const float4* xt, const SphList list, const uint nf) {
  const float H = p->support;
  float8 fx = (float8)(0.0f), fy = fx, fz = fx;
  uint k = 0;
#if SPH_PAIR16
  for (; k + 16 <= nf; k += 16) {
    const uint16 j = sph_list16(list, k);
    SPH_LOAD16(x, xt, j);
    const float16 dx = xi.x - x_x, dy = xi.y - x_y, dz = xi.z - x_z;
    SPH_GRAD_FACTOR16(F, sqrt(dx * dx + dy * dy + dz * dz), H);
    const float16 c = (ti + x_w) * F;
    fx -= c.lo * dx.lo;
    fy -= c.lo * dy.lo;
    fz -= c.lo * dz.lo;
    fx -= c.hi * dx.hi;
    fy -= c.hi * dy.hi;
    fz -= c.hi * dz.hi;
  }
#endif
  for (; k + 8 <= nf; k += 8) {
    const uint8 j = sph_list8(list, k);
    SPH_LOAD8(x, xt, j);
    const float8 dx = xi.x - SPH_LANES8(x, x), dy = xi.y - SPH_LANES8(x, y), dz = xi.z - SPH_LANES8(x, z);
    const float8 F = sph_grad_factor8(sqrt(dx * dx + dy * dy + dz * dz), H);
    const float8 c = (ti + SPH_LANES8(x, w)) * F;
    fx -= c * dx;
    fy -= c * dy;
    fz -= c * dz;
  }
  float3 f = (float3)(sph_hsum8(fx), sph_hsum8(fy), sph_hsum8(fz));
  for (; k < nf; ++k) {
    const float4 xj = xt[sph_list1(list, k)];
    const float3 d = xi - xj.xyz;
    f -= (ti + xj.w) * sph_grad_factor(SPH_KERNEL, length(d), H) * d;
  }
  return f;
}
SPH_PSABI_LOUD

/* The pressure force of the top of this file on particle i (unit: N), for the pressures `pr`.
 * Performance: the fluid neighbours' positions and p_j / delta_j^2 come packed in one float4 each,
 * xt_j = (x_j, p_j / delta_j^2) (written with the pressures by dfsph_source and dfsph_jacobi), one
 * gather per neighbour instead of five (position, phase, mass, density, pressure). Inlined by force
 * (SPH_HOT, shared/pair_loops.h). */
SPH_PSABI_QUIET
SPH_HOT float3 dfsph_force(const SimParams* p, const uint i, __global const float4* xt, __global const uint* phase,
                           __global const float* density, __global const float* pr, __global const uint* nbr,
                           const uint nf, __global const float4* bpos, __global const uint* blist, const uint nb,
                           const float wall, __global const float* bpr, const int use_bp, const float4 gw) {
  const float H = p->support;
  const float3 xi = xt[i].xyz;
  const float di = density[i] / p->phase_mass[phase[i]];
  const float ti = pr[i] / (di * di); /* p_i / delta_i^2 */
  /* i's fluid list, narrow or wide (shared/neighbours.h), made here rather than passed in: when this
   * function was not inlined, a list passed by value cost ~10 % of the pass (performance); the helper
   * below is inlined by force */
  const SphList list = sph_list(p, nbr, i);
  float3 f = dfsph_fluid_pressure_force(p, xi, ti, xt, list, nf);
  /* walls: wall = 2 mirrors the pressure (p_b = p_i, delta_b = delta_i), wall = 1 is Akinci's
   * single term (p_b = 0 in the symmetric sum); extrapolated (use_bp): wall = 1 and the wall
   * particle's own pressure p_b (Adami et al. 2012 eq. 27, bpr) in the symmetric sum, over delta_i^2 */
  f -= wall * ti * gw.xyz; /* sum_b psi_b wall t_i gradW_ib = wall t_i G_b */
  if (use_bp) f -= dfsph_wall_sums(xi, blist, nb, bpos, 0, bpr, H).xyz / (di * di);
  return f;
}
SPH_PSABI_LOUD

/* Pressure accelerations a_i^p = f_i / m_i of the current pressures (unit: m/s^2). */
__kernel void dfsph_pressure_accel(const SimParams p, __global const float4* xt, __global const uint* phase,
                                   __global const float* density, __global const float* pressure,
                                   __global const uint* nbr, __global const uint* nbr_count,
                                   __global const float4* bpos, __global const uint* bnbr,
                                   __global const uint* bnbr_count, const float wall, __global const float* bpr,
                                   const int use_bp, __global float4* accel, __global const float4* gwall) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float3 f = dfsph_force(&p, i, xt, phase, density, pressure, nbr, nbr_count[i], bpos,
                               bnbr + (size_t)i * K, bnbr_count[i], wall, bpr, use_bp, gwall[i]);
  accel[i] = (float4)(f / p.phase_mass[phase[i]], 0.0f);
}

/* The density solve's start in two passes instead of one with neighbours and the first iteration's
 * (core/dfsph.cpp, DfsphSolver::source; performance): where the warm start does not depend on the
 * source (dfsph_source with warm_all, extrapolated walls, and kind 1, which leaves no particle out by
 * its neighbour count), the starting pressure and xt come first, from the particle alone
 * (dfsph_warm_pack: dfsph_source's p0 and xt), then the wall pressures of that pressure
 * (dfsph_wall_list_pressure), then dfsph_source_accel: the source of dfsph_source (kind 1) and the
 * accelerations of dfsph_pressure_accel, which the first iteration would compute next. The same
 * functions on the same values give the same bits; the two loops over i's neighbours follow each
 * other in one work-item, so the second finds the list and the neighbours' xt in the cache. */
__kernel void dfsph_warm_pack(const SimParams p, __global const float4* pos, __global const uint* phase,
                              __global const float* density, const float warm, __global float* pressure,
                              __global float4* xt) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  dfsph_start_pressure(i, warm * pressure[i], density[i] / p.phase_mass[phase[i]], pos, pressure, xt);
}

__kernel void dfsph_source_accel(const SimParams p, __global const float4* xt, __global const float4* vel,
                                 __global const uint* phase, __global const float* density,
                                 __global const float* pressure, __global const uint* nbr,
                                 __global const uint* nbr_count, __global const float4* bpos,
                                 __global const uint* bnbr, __global const uint* bnbr_count, const float wall,
                                 __global const float* bpr, const int use_bp, __global float4* accel,
                                 __global const float4* gwall, __global float* source) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const uint nf = nbr_count[i];
  const float4 gw = gwall[i];
  /* dfsph_source, kind 1: positions from xt (the same bits as pos) */
  const float rate = dfsph_density_rate(&p, i, xt, vel, nbr, nf, gw);
  source[i] = dfsph_compression(&p, density[i] / p.phase_mass[phase[i]], rate);
  /* dfsph_pressure_accel */
  const float3 f = dfsph_force(&p, i, xt, phase, density, pressure, nbr, nf, bpos, bnbr + (size_t)i * K,
                               bnbr_count[i], wall, bpr, use_bp, gw);
  accel[i] = (float4)(f / p.phase_mass[phase[i]], 0.0f);
}

/* One relaxed Jacobi iteration (the formulas at the top of this file): the residual
 * r_i = s_i + dt^2 V0 (sum_j (a_i - a_j) . gradW_ij + sum_b psi_b a_i . gradW_ib), the pressure
 * p_i <- max(p_i + omega r_i alpha_i / (dt^2 V0), 0), err_i = max(r_i, 0) before the update (as the
 * reference). Divergence solve: a particle with fewer than `min_neighbours` neighbours (free
 * surface, splashes) has a density rate that is not that of a full support; it takes no pressure
 * and its error is not counted (as the reference). Chebyshev semi-iteration (core/dfsph.cpp, iterate()):
 * with the weight cheb other than 0 or 1 the new pressure is max(pold_i + cheb (p_jacobi - pold_i), 0), pold_i
 * the iterate before the last; with cheb != 0 pold_i keeps this iteration's starting p_i for the next one
 * (cheb 0: plain Jacobi, pold untouched). Reads the neighbours' accelerations, writes only particle i. */
SPH_PSABI_QUIET
__kernel void dfsph_jacobi(const SimParams p, __global const float4* pos, __global const float4* accel,
                           __global const float* alpha, __global const float* source, __global const uint* nbr,
                           __global const uint* nbr_count, __global const float4* bpos, __global const uint* bnbr,
                           __global const uint* bnbr_count, const uint min_neighbours, const float omega,
                           const int two_sided, __global float* pressure, __global float* err,
                           __global const uint* phase, __global const float* density, __global float4* xt,
                           __global const float4* gwall, const int nodes, __global const float4* bacc,
                           const float cheb, __global float* pold) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float H = p.support;
  const float3 xi = pos[i].xyz, ai = accel[i].xyz;
  const uint nf = nbr_count[i], nb = bnbr_count[i];
  /* divergence solve: a particle with fewer than min_neighbours neighbours keeps no pressure (its
   * residual is not needed: checked before the neighbour loop) */
  if (nf + nb < min_neighbours) {
    err[i] = 0.0f;
    return;
  }
  const SphList list = sph_list(&p, nbr, i); /* narrow or wide (shared/neighbours.h) */
  /* sum_j (a_i - a_j) . gradW_ij: sixteen at a time, then eight, then the rest (as dfsph_force) */
  float8 acc = (float8)(0.0f);
  uint k = 0;
#if SPH_PAIR16
  for (; k + 16 <= nf; k += 16) {
    const uint16 j = sph_list16(list, k);
    SPH_LOAD16(x, pos, j);
    SPH_LOAD16(a, accel, j);
    const float16 dx = xi.x - x_x, dy = xi.y - x_y, dz = xi.z - x_z;
    SPH_GRAD_FACTOR16(F, sqrt(dx * dx + dy * dy + dz * dz), H);
    const float16 t = (ai.x - a_x) * dx + (ai.y - a_y) * dy + (ai.z - a_z) * dz;
    acc += F.lo * t.lo;
    acc += F.hi * t.hi;
  }
#endif
  for (; k + 8 <= nf; k += 8) {
    const uint8 j = sph_list8(list, k);
    SPH_LOAD8(x, pos, j);
    SPH_LOAD8(a, accel, j);
    const float8 dx = xi.x - SPH_LANES8(x, x), dy = xi.y - SPH_LANES8(x, y), dz = xi.z - SPH_LANES8(x, z);
    const float8 F = sph_grad_factor8(sqrt(dx * dx + dy * dy + dz * dz), H);
    acc += F * ((ai.x - SPH_LANES8(a, x)) * dx + (ai.y - SPH_LANES8(a, y)) * dy + (ai.z - SPH_LANES8(a, z)) * dz);
  }
  float Ap = sph_hsum8(acc);
  for (; k < nf; ++k) {
    const uint j = sph_list1(list, k);
    const float3 d = xi - pos[j].xyz;
    Ap += sph_grad_factor(SPH_KERNEL, length(d), H) * dot(ai - accel[j].xyz, d);
  }
  Ap += dot(ai, gwall[i].xyz); /* sum_b psi_b a_i . gradW_ib = a_i . G_b */
  /* nodes: the cloth nodes' pressure accelerations (dfsph_node_accel; 0 for the other boundary
   * particles), - sum_b psi_b a_b . gradW_ib */
  if (nodes) Ap -= dfsph_node_sum(xi, bnbr + (size_t)i * K, nb, bpos, bacc, H);
  const float r = source[i] + p.dt * p.dt * p.rest_volume * Ap;
  const float inc = omega * r * alpha[i] / (p.dt * p.dt * p.rest_volume);
  const float p0 = pressure[i];
  float p1 = fmax(p0 + inc, 0.0f);
  if (cheb != 0.0f && cheb != 1.0f) {
    const float pm = pold[i];
    p1 = fmax(pm + cheb * (p1 - pm), 0.0f);
  }
  if (cheb != 0.0f) pold[i] = p0;
  pressure[i] = p1;
  err[i] = (two_sided && p0 > 0.0f) ? fabs(r) : fmax(r, 0.0f);
  /* the packed position and p / delta^2 that the next pressure-force pass gathers (dfsph_force) */
  const float di = density[i] / p.phase_mass[phase[i]];
  xt[i] = (float4)(xi, p1 / (di * di));
}
SPH_PSABI_LOUD

/* The end of a solve: the velocities take the pressures, v_i += dt a_i^p. */
__kernel void dfsph_apply_pressure(const SimParams p, __global const float4* xt, __global float4* vel,
                          __global const uint* phase, __global const float* density, __global const float* pressure,
                          __global const uint* nbr, __global const uint* nbr_count, __global const float4* bpos,
                          __global const uint* bnbr, __global const uint* bnbr_count, const float wall,
                          __global const float* bpr, const int use_bp, __global const float4* gwall) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float3 f = dfsph_force(&p, i, xt, phase, density, pressure, nbr, nbr_count[i], bpos,
                               bnbr + (size_t)i * K, bnbr_count[i], wall, bpr, use_bp, gwall[i]);
  vel[i] += (float4)(p.dt / p.phase_mass[phase[i]] * f, 0.0f);
}

/* --- Mirrored walls: increments from the velocities, applied each iteration ----------------- */

/* Warm start (B&K 2017 section 4.4, as the reference implementation does it): half the previous
 * step's accumulated pressure, and only where the current velocities compress. (The full pressure,
 * everywhere, ratcheted up: increments are >= 0, so a pressure left at a particle that had since
 * expanded pushed on, step after step; the hydrostatic tank blew up at 0.6 s.) */
inline float dfsph_warm(const bool compressing, const float previous) {
  return compressing ? 0.5f * previous : 0.0f;
}

/* Source of the divergence solve (B&K 2017 Alg. 2, eq. 15): p_i = (D delta_i / Dt) alpha_i / dt.
 * Particles with fewer than `min_neighbours` neighbours (free surface, splashes) are left alone,
 * as in the reference implementation: their density rate is not that of a full support.
 * err_i = max(D delta_i / Dt, 0) V0 dt: the relative density change over one step. */
__kernel void dfsph_divergence_source(const SimParams p, __global const float4* pos, __global const float4* vel,
                                      __global const float* alpha, __global const uint* nbr,
                                      __global const uint* nbr_count, __global const float4* bpos,
                                      __global const float4* bvel, __global const uint* bnbr,
                                      __global const uint* bnbr_count, const uint min_neighbours,
                                      const int warm, const float omega, __global const float* pprev,
                                      __global float* pinc,
                                      __global float* err, __global const uint* phase,
                                      __global const float* density, __global float4* xt,
                                      __global const float4* gwall) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const uint nf = nbr_count[i], nb = bnbr_count[i];
  float rate = dfsph_density_rate(&p, i, pos, vel, nbr, nf, gwall[i]);
  if (nf + nb < min_neighbours) rate = 0.0f;
  const float pi = warm ? dfsph_warm(rate > 0.0f, pprev[i]) : fmax(omega * rate * alpha[i] / p.dt, 0.0f);
  pinc[i] = pi;
  err[i] = fmax(rate, 0.0f) * p.rest_volume * p.dt;
  const float di = density[i] / p.phase_mass[phase[i]];
  xt[i] = (float4)(pos[i].xyz, pi / (di * di)); /* packed for dfsph_apply_increments */
}

/* Source of the density solve (B&K 2017 Alg. 3, eq. 12): delta*_i = delta_i + dt D delta_i / Dt,
 * p_i = (delta*_i - delta0) alpha_i / dt^2. err_i = max(delta*_i V0 - 1, 0): the relative
 * compression the current velocities would leave at the end of the step. */
__kernel void dfsph_density_source(const SimParams p, __global const float4* pos, __global const float4* vel,
                                   __global const uint* phase, __global const float* density,
                                   __global const float* alpha, __global const uint* nbr,
                                   __global const uint* nbr_count, __global const float4* bpos,
                                   __global const float4* bvel, __global const uint* bnbr,
                                   __global const uint* bnbr_count, const int warm, const float omega,
                                   __global const float* pprev,
                                   __global float* pinc, __global float* err, __global float4* xt,
                                   __global const float4* gwall) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float rate = dfsph_density_rate(&p, i, pos, vel, nbr, nbr_count[i], gwall[i]);
  const float delta = density[i] / p.phase_mass[phase[i]];
  const float s = (delta + p.dt * rate) * p.rest_volume - 1.0f; /* relative density error */
  const float pi = warm ? dfsph_warm(s > 0.0f, pprev[i]) : fmax(omega * s / p.rest_volume * alpha[i] / (p.dt * p.dt), 0.0f);
  pinc[i] = pi;
  err[i] = fmax(s, 0.0f);
  xt[i] = (float4)(pos[i].xyz, pi / (delta * delta)); /* packed for dfsph_apply_increments */
}

/* Mirrored walls (fluid.dfsph.walls: mirrored), the iteration of the first version: each
 * iteration computes increments from the velocities (the sources above) and applies them here.
 * Applies the pressures pinc: v_i += dt a_i^p (the force at the top of this file), and adds them to
 * the accumulated pressure. Reads the neighbours' pressures, writes only particle i. */
SPH_PSABI_QUIET
__kernel void dfsph_apply_increments(const SimParams p, __global const float4* xt, __global float4* vel,
                          __global const uint* phase, __global const float* density, __global const float* pinc,
                          __global float* pacc, __global const uint* nbr, __global const uint* nbr_count,
                          __global const float4* bpos, __global const uint* bnbr, __global const uint* bnbr_count,
                          __global const float4* gwall) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 xi = xt[i].xyz;
  const float mi = p.phase_mass[phase[i]];
  const float di = density[i] / mi;
  const float ti = pinc[i] / (di * di); /* p_i / delta_i^2 */
  const SphList list = sph_list(&p, nbr, i); /* narrow or wide (shared/neighbours.h) */
  /* pressure force (unit: N): the fluid's (dfsph_fluid_pressure_force; xt packs the positions and
   * p_j / delta_j^2) */
  float3 f = dfsph_fluid_pressure_force(&p, xi, ti, xt, list, nbr_count[i]);
  f -= 2.0f * ti * gwall[i].xyz; /* walls mirror the pressure: sum_b psi_b 2 t_i gradW_ib = 2 t_i G_b */
  vel[i] += (float4)(p.dt / mi * f, 0.0f);
  pacc[i] += pinc[i];
}
SPH_PSABI_LOUD

/* Per-chunk sums of err (chunk c: particles c*chunk .. (c+1)*chunk - 1, in order), for the average
 * error; the host adds the chunks in order: a fixed order, so runs are bitwise deterministic. */
__kernel void dfsph_reduce(const uint n, const uint chunk, __global const float* err, __global float* partial) {
  const uint c = get_global_id(0);
  const uint begin = c * chunk;
  const uint end = min(begin + chunk, n);
  float s = 0.0f;
  for (uint k = begin; k < end; ++k) s += err[k];
  partial[c] = s;
}

/* Extrapolated walls: contact with the domain walls for the particles the solve leaves without
 * pressure. A free-surface or splash particle at a wall (a thin layer spreading on the floor, the
 * sheet running up a side wall) has a cut support, so its density stays below delta0 and the
 * projected solve gives it p = 0; then only the walls' extrapolated pressure, about rho0 g dx,
 * holds it, too little to carry its weight: it sank through the wall plane (the integrator put it
 * back and counted a wall crossing; 50-100 in 0.6 s of the 50k dam break). As WCSPH's contact
 * (shared/pair_loops.h, sph_boundary_contact, in the spirit of Monaghan & Kajtar 2009), a linear
 * repulsion from each wall particle inside r0 = `range` dx, zero from there on:
 *     a_i += sum_b psi_b k_w (1 - r/r0) x_ib / r,    k_w = `stiffness` dx / dt^2 (unit: m/s^2),
 * its stiffness tied to the step instead of c0 (DFSPH has none), so that it is stable at any step
 * (core/dfsph.cpp says why `stiffness` 0.3 and `range` 0.75, what it stops and what not). It acts
 * on any particle closer than r0 to a wall particle (at rest none is: they sit dx away), whatever
 * its pressure. Walls only (bvel.w = 0; also cloth nodes, when cloth runs with DFSPH): bodies keep
 * the solver's coupling, so Newton's third law with the rigid coupling (rigid.cl) is unchanged.
 * A static rigid body's sampled layer (bnormal.w = 1; read only when `sampled`: without static
 * bodies bnormal is a placeholder) takes it too, over the wider `sampled_range`
 * dx, as WCSPH's contact does (shared/pair_loops.h, sph_boundary_contact): that layer is one
 * particle thick and sampled irregularly (rigid::sampleSurface), so points of its surface lie up to
 * ~0.75 dx from every particle (core/dfsph.cpp, kSampledContactRange; dfsph_surface_impulse below
 * says what went wrong there).
 * Added to the non-pressure accelerations in the prediction before the density solve (dfsph_predict,
 * `contact`: one pass fewer than a kernel of its own). */
inline float3 dfsph_wall_contact_accel(const SimParams* p, const uint i, __global const float4* pos,
                                       __global const float4* bpos, __global const float4* bvel,
                                       __global const float4* bnormal, __global const uint* bnbr,
                                       __global const uint* bnbr_count, const float stiffness, const float range,
                                       const float sampled_range, const int sampled) {
  /* no wall particle within H: no contact (and no cube root, which cost as much as the loop) */
  const uint nb = bnbr_count[i];
  if (nb == 0) return (float3)(0.0f);
  const float dx = cbrt(p->rest_volume); /* (unit: m) */
  const float r_wall = range * dx;                  /* (unit: m) */
  const float r_sampled = sampled_range * dx;       /* (unit: m) */
  const float k = stiffness * dx / (p->dt * p->dt); /* (unit: m/s^2) */
  const float3 xi = pos[i].xyz;
  __global const uint* list = bnbr + (size_t)i * p->max_neighbours;
  /* a squared distance just above the larger range's square (the 1 % margin covers length()'s
   * rounding) screens out the boundary particles beyond it (most of those within H) before the
   * square root and the kind check; the pairs inside are computed as before */
  const float r_max = sampled ? fmax(r_wall, r_sampled) : r_wall;
  const float r0_screen = 1.01f * 1.01f * r_max * r_max; /* (unit: m^2) */
  float3 a = (float3)(0.0f);
  for (uint m = 0; m < nb; ++m) {
    const uint b = list[m];
    const float4 bb = bpos[b];
    const float3 d = xi - bb.xyz;
    if (dot(d, d) >= r0_screen) continue;
    if (bvel[b].w > 0.5f) continue; /* a moving body's particle */
    const float r0 = sampled && bnormal[b].w > 0.0f ? r_sampled : r_wall;
    const float r = length(d);
    if (r < r0 && r > 1e-6f * dx) a += bb.w * k * (1.0f - r / r0) / r * d;
  }
  return a;
}

/* Non-pressure forces (gravity, viscosity: acc; with `contact` the extrapolated walls' contact)
 * before the density solve: v* = v + dt a; acc is cleared, so that the integrator's v += dt a adds
 * nothing after the solve. */
__kernel void dfsph_predict(const SimParams p, __global float4* vel, __global float4* acc, const int contact,
                            __global const float4* pos, __global const float4* bpos, __global const float4* bvel,
                            __global const float4* bnormal, __global const uint* bnbr, __global const uint* bnbr_count,
                            const float stiffness, const float range, const float sampled_range, const int sampled) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  float4 a = acc[i];
  /* extrapolated walls (contact): the wall contact first (dfsph_wall_contact_accel, above) */
  if (contact) a += (float4)(dfsph_wall_contact_accel(&p, i, pos, bpos, bvel, bnormal, bnbr, bnbr_count, stiffness, range, sampled_range, sampled), 0.0f);
  vel[i] += p.dt * a;
  acc[i] = (float4)(0.0f);
}

/* One axis a of dfsph_wall_impulse (below): the velocity va of a particle at xa, by the low wall (mask bit 2a) and the high (2a + 1). */
inline float dfsph_wall_impulse_axis(const SimParams* p, const int a, const float lo, const float hi,
                                     const float gap, const float xa, float va) {
  /* low wall: the velocity that reaches the plane min + gap in this step, or 0 inside the gap */
  if ((p->closed_mask >> (2 * a)) & 1u) va = fmax(va, fmin((lo + gap - xa) / p->dt, 0.0f));
  /* high wall: the same, mirrored */
  if ((p->closed_mask >> (2 * a + 1)) & 1u) va = fmin(va, fmax((hi - gap - xa) / p->dt, 0.0f));
  return va;
}

/* Extrapolated walls: the closed domain walls as a unilateral contact (a non-penetration condition
 * on the velocity, Signorini's condition x_n >= gap written for one step of the symplectic update
 * x += dt v, as velocity-level contact solvers do: Moreau 1988, "Unilateral contact and dry
 * friction in finite freedom dynamics"; particle fluids solved for incompressibility handle their
 * solid boundaries so too, e.g. Macklin & Mueller 2013, "Position Based Fluids", their collision response), after
 * the density solve: the velocity
 * the integrator moves the particle with never brings its centre closer than `gap` to a closed wall's
 * plane. Its normal component toward the wall is cut to what reaches the plane at `gap` in this step,
 *     v_n >= min((gap - x_n) / dt, 0)     (x_n: distance to the wall plane, v_n: velocity away from it),
 * a perfectly inelastic impact (the wall, fixed, takes the normal momentum; the tangential velocity
 * is kept), and nothing more: it never pushes a particle out (inside `gap` it only stops the approach),
 * so it adds no energy and leaves what the pressure and the contact above do between the gap and the
 * rest position alone. Why (issue 14, measured on scenes/tests/dfsph_floor.yaml): a layer of water
 * one particle thick has a cut support, rho ~ 0.5-0.8 rho0, so the density solve's unilateral
 * condition rho* <= rho0 never becomes active at the floor (p = 0 all the way through it) and the
 * contact above reaches only 0.25 dx above the plane over a wall particle and nowhere over the
 * hollows between them: a sheet landing at 1.4 m/s went through the floor in 2 steps (rho 536, 692,
 * 919 kg/m^3, p = 0), and the particles that rest on the floor slid into the hollows and sank (p = 0,
 * 0.03 m/s down). gap (unit: m) > 0 keeps every centre inside the domain: no wall crossing. */
__kernel void dfsph_wall_impulse(const SimParams p, __global const float4* pos, __global float4* vel, const float gap) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float4 x4 = pos[i];
  const float4 v4 = vel[i];
  /* the three axes written out (a loop over arrays indexed by the axis ran ~3x slower on pocl: performance) */
  vel[i] = (float4)(dfsph_wall_impulse_axis(&p, 0, p.domain_min[0], p.domain_max[0], gap, x4.x, v4.x),
                    dfsph_wall_impulse_axis(&p, 1, p.domain_min[1], p.domain_max[1], gap, x4.y, v4.y),
                    dfsph_wall_impulse_axis(&p, 2, p.domain_min[2], p.domain_max[2], gap, x4.z, v4.z), v4.w);
}

/* Extrapolated walls: a static rigid body's surface as a unilateral contact, as dfsph_wall_impulse
 * makes the closed walls one: the velocity the integrator moves a particle with never brings its
 * centre closer than `gap` to the surface,
 *     v_n >= min((gap - x_n) / dt, 0),   x_n = n_b . (x_i - x_b) - dx/2,
 * with n_b the outward normal of the body's particle b nearest to i among those i is in front of
 * (n_b . (x_i - x_b) >= 0; the sampled layer lies dx/2 inside the surface: core/model.cpp) and x_n the
 * distance from the surface's plane there; the tangential velocity is kept. (In front only: in a body
 * thinner than dx the two faces' layers cross, and the other face's particle would hold i back from
 * leaving; a particle behind every layer, inside a body, is left alone.) Why: a body's one sampled layer has holes (points of its surface up to
 * ~0.75 dx from every particle), and a particle that reached the layer's plane in one felt no push
 * back (the pressure and contact forces of a layer are tangential in its own plane). In
 * scenes/demo_painting.yaml with DFSPH, water at rest crept through the tray's wall face from
 * t = 0.11 s; the density solve diverged about the particles inside (their factor 20x their
 * neighbours'), and the run blew up at 0.544 s; with the wider contact alone (r0 = dx) the stirring
 * still pushed 3 particles through by 1.1 s (core/dfsph.cpp, kSurfaceGap). The nearest particle's
 * plane is the surface's within the sampling (exact on a flat face; on a curved one of radius R
 * off by ~dx^2 / R); it never pushes a particle out, so it adds no energy. A static body does not
 * move, so no reaction is owed. Moving bodies keep the solver's coupling
 * (their momentum balance with the fluid is the rigid coupling's). */
__kernel void dfsph_surface_impulse(const SimParams p, __global const float4* pos, __global float4* vel,
                                    __global const float4* bpos, __global const float4* bnormal,
                                    __global const uint* bnbr, __global const uint* bnbr_count, const float gap) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint nb = bnbr_count[i];
  if (nb == 0) return;
  const float3 xi = pos[i].xyz;
  __global const uint* list = bnbr + (size_t)i * p.max_neighbours;
  float best = INFINITY;
  uint nearest = 0;
  for (uint m = 0; m < nb; ++m) {
    const uint b = list[m];
    const float4 nb4 = bnormal[b];
    if (nb4.w == 0.0f) continue; /* not a static body's particle */
    const float3 d = xi - bpos[b].xyz;
    if (dot(nb4.xyz, d) < 0.0f) continue; /* i is behind this particle's layer */
    const float r2 = dot(d, d);
    if (r2 < best) best = r2, nearest = b;
  }
  if (best == INFINITY) return;
  const float dx = cbrt(p.rest_volume); /* (unit: m) */
  const float3 n = bnormal[nearest].xyz;
  const float xn = dot(n, xi - bpos[nearest].xyz) - 0.5f * dx; /* (unit: m) */
  float4 v = vel[i];
  const float vn = dot(v.xyz, n);
  const float vmin = fmin((gap - xn) / p.dt, 0.0f);
  if (vn < vmin) v.xyz += (vmin - vn) * n;
  vel[i] = v;
}

/* After both solves: the pressure to export and what the rigid coupling reads, both of all the
 * pressure that acted this step. Both solves apply v += dt a^p(p) at the same positions and number
 * densities and a^p is linear in p, so the step's momentum change is that of p_div + p_dens: the
 * physical pressure over the step (the one a WCSPH run reports) is their sum (Pa). (The density
 * solve's alone reads low at rest, by the share of the weight the divergence solve carries: 10 % in
 * the hydrostatic tank.) The rigid coupling reads p / delta^2 of the same sum, so the reaction on
 * bodies balances what the fluid received: Newton's third law. */
__kernel void dfsph_finish(const SimParams p, __global const uint* phase, __global const float* density,
                           __global const float* pdiv, __global const float* pdens, __global float* pressure,
                           __global float* pterm, volatile __global uint* max_pressure_bits) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float d = density[i] / p.phase_mass[phase[i]];
  pressure[i] = pdiv[i] + pdens[i];
  pterm[i] = (pdiv[i] + pdens[i]) / (d * d);
  /* the step's largest p_i / rho_i (unit: m^2/s^2), for the pressure step bound (fluid.dfsph.pressure_cfl,
   * Simulation::dfsphStepLimit); an integer atomic max of a non-negative float's bits: exact, any order */
  const uint qb = as_uint(fmax((pdiv[i] + pdens[i]) / density[i], 0.0f));
  if (qb > *max_pressure_bits) atomic_max(max_pressure_bits, qb); /* read first: few atomics */
}

/* The accumulated pressures follow their particles when the grid stage reorders them (grid.cl,
 * grid_reorder: slot s takes particle sorted[s]). */
__kernel void dfsph_reorder(const uint n, __global const uint* sorted, __global const float* a,
                            __global const float* b, __global float* a_out, __global float* b_out) {
  const uint s = get_global_id(0);
  if (s >= n) return;
  const uint j = sorted[s];
  a_out[s] = a[j];
  b_out[s] = b[j];
}

/* One buffer's values follow their particles (the last density pressure of warm_average). */
__kernel void dfsph_reorder_one(const uint n, __global const uint* sorted, __global const float* a,
                                __global float* a_out) {
  const uint s = get_global_id(0);
  if (s >= n) return;
  a_out[s] = a[sorted[s]];
}

/* The density solve's warm start averaged over the last two steps (fluid.dfsph.warm_average,
 * docs/dfsph.md session 29): p_i <- p_i + gamma (p_prev_i - p_i), p the last step's pressure and
 * p_prev the one before. What the last solve added to correct that step's own error, a push that
 * restarted in full is applied twice, enters at 1 - gamma; what the column's weight or a body
 * resting on the water needs in every step is in both and passes unchanged. */
__kernel void dfsph_warm_average(const uint n, __global float* pressure, __global const float* previous,
                                 const float gamma) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  pressure[i] += gamma * (previous[i] - pressure[i]);
}

/* Extrapolated walls: the wall pressures of the two solves add up (both are linear in the fluid's
 * pressures but for the projection to >= 0), so the rigid coupling sees all that acted: a += b. */
__kernel void dfsph_add(const uint n, __global float* a, __global const float* b) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  a[i] += b[i];
}


/* --- Extrapolated walls: the wall pressure from per-step lists (performance) ----------------- */

/* Once per step, after the density pass: for each boundary particle b that some fluid particle saw
 * this step (bmark == stamp), the fluid particles within H, in the order boundary_pressure
 * (pressure.cl) visits them (the grid's cells, in cell order), and the list of those b (`active`;
 * ~10 % of the walls' particles in the 50k dam break); the others' wall pressures are set to 0.
 * Positions do not change during a step's solves, so each iteration's wall pressure
 * (dfsph_wall_list_pressure) reads these ~20
 * instead of scanning the 27 cells (~290 candidates). A list longer than `slots` keeps its
 * count (> slots), and dfsph_wall_list_pressure scans the cells for that b as before. */
__kernel void dfsph_wall_lists(const SimParams p, const uint n_boundary, const uint stamp,
                               __global const float4* bpos, __global const uint* bmark,
                               __global const float4* pos, __global const uint* cell_start, const uint slots,
                               __global uint* wlist, __global uint* wcount, __global float* bp_a,
                               __global float* bp_b, volatile __global uint* n_active, __global uint* active,
                               __global const float* density, __global float* wweight, __global float4* wsum) {
  const uint b = get_global_id(0);
  /* b joins the step's active wall particles, the only ones dfsph_wall_list_pressure visits: a
   * slot in the work-group (a local counter), then the work-group's block in the list (one global
   * integer atomic per work-group: one per particle contended). The list's order varies from run
   * to run, but each entry's pressure depends on its own b alone: the results do not. */
  __local uint group_count, group_base;
  if (get_local_id(0) == 0) group_count = 0;
  barrier(CLK_LOCAL_MEM_FENCE);
  const int marked = b < n_boundary && bmark[b] == stamp;
  const uint slot = marked ? atomic_inc(&group_count) : 0u;
  barrier(CLK_LOCAL_MEM_FENCE);
  if (get_local_id(0) == 0) group_base = atomic_add(n_active, group_count);
  barrier(CLK_LOCAL_MEM_FENCE);
  if (b >= n_boundary) return;
  /* no fluid near b this step: no pressure in either solve (written here, once per step) */
  if (!marked) {
    wcount[b] = 0;
    bp_a[b] = 0.0f;
    bp_b[b] = 0.0f;
    return;
  }
  active[group_base + slot] = b;
  const float3 xb = bpos[b].xyz;
  const float H = p.support;
  __global uint* out = wlist + (size_t)b * slots;
  __global float* wout = wweight + (size_t)b * slots;
  /* the list, each pair's W_bf, and the sums that do not depend on the pressures (sum_f W_bf and
   * sum_f rho_f W_bf x_bf), accumulated in list order with boundary_pressure's arithmetic */
  /* candidates eight at a time, row by row (shared/pair_loops.h, sph_collect_row), within a radius
   * a little above H, in the cells' order; then the exact test of boundary_pressure, in place */
  uint n = 0;
  SPH_FOR_NEIGHBOUR_ROWS(&p, cell_start, xb, begin, end) {
    n = sph_collect_row(xb, pos, begin, end, 1.0001f * H * H, 0xffffffffu, out, 0, 0, slots, n);
  }
  SPH_END_NEIGHBOURS
  if (n > slots) { /* too many: dfsph_wall_list_pressure scans the cells for b */
    wcount[b] = n;
    return;
  }
  uint kept = 0;
  float sw = 0.0f;
  float3 srw = (float3)(0.0f);
  for (uint m = 0; m < n; ++m) {
    const uint f = out[m];
    const float3 d = xb - pos[f].xyz;
    const float r2 = dot(d, d);
    if (r2 < H * H) {
      const float w = sph_w(SPH_KERNEL, sqrt(r2), H);
      sw += w;
      srw += (density[f] * w) * d;
      out[kept] = f;
      wout[kept] = w;
      ++kept;
    }
  }
  wcount[b] = kept;
  wsum[b] = (float4)(srw, sw);
}

/* Wall pressure p_b of pressure.cl's boundary_pressure (Adami, Hu & Adams 2012 eq. 27; the
 * formula and the clamp in shared/wall_pressure.h), from the lists of dfsph_wall_lists: the same
 * pairs in the same order with the same arithmetic, so p_b is bitwise boundary_pressure's. The weights W_bf and the
 * pressure-free sums come from dfsph_wall_lists (positions and densities do not change during a
 * step's solves): each iteration gathers the pressures alone (performance). */
__kernel void dfsph_wall_list_pressure(const SimParams p, const uint n_active, __global const uint* active,
                                       __global const float4* bpos, __global const float4* pos,
                                       __global const float* density, __global const float* pressure,
                                       __global const uint* cell_start, const uint slots,
                                       __global const uint* wlist, __global const uint* wcount,
                                       __global float* bpressure, __global const float* wweight,
                                       __global const float4* wsum) {
  /* the step's active wall particles only (dfsph_wall_lists: the others' pressure is 0 already) */
  const uint a = get_global_id(0);
  if (a >= n_active) return;
  const uint b = active[a];
  float sw, spw = 0.0f;
  float3 srw;
  const uint n = wcount[b];
  if (n <= slots) {
    /* the listed fluid particles, all within H, with the step's weights and sums (dfsph_wall_lists):
     * only sum_f p_f W_bf is left to each iteration */
    __global const uint* list = wlist + (size_t)b * slots;
    __global const float* wl = wweight + (size_t)b * slots;
    for (uint m = 0; m < n; ++m) spw += pressure[list[m]] * wl[m];
    const float4 ws = wsum[b];
    srw = ws.xyz;
    sw = ws.w;
  } else {
    /* a list that overflowed: the cells, as boundary_pressure */
    sph_wall_sums_from_cells(&p, cell_start, bpos[b].xyz, pos, density, pressure, &sw, &spw, &srw);
  }
  bpressure[b] = sph_wall_pressure(&p, sw, spw, srw);
}

/* --- Cloth nodes inside the solves (strong coupling, session 17) ----------------------------
 * A cloth node is a boundary particle for the fluid, but unlike a wall it moves under the pressure
 * the solve is finding. Staggered (the node answering the pressure only after the step), a light
 * node between incompressible water swings with period 2 steps and grows (the added-mass
 * instability: scenes/balls_on_cloth.yaml blew up at t = 0.043 s, and at 0.79 s even at 1 ms
 * steps). So each iteration moves the free nodes under the pressure force of the current pressures
 * (dfsph_node_accel), and the residual of every fluid particle near them counts -sum_b psi_b a_b .
 * gradW_ib (dfsph_jacobi), as it counts its fluid neighbours' accelerations: fluid and nodes meet
 * the density constraint together, as Gissler et al. 2019 ("Interlinked SPH pressure solvers for
 * strong fluid-rigid coupling") do for rigid bodies. How a node answers (dfsph_node_slots):
 *  - water on both sides of the sheet (the sandwich): the water's inertia holds the node's motion
 *    across the sheet, not its springs, so it moves as its mass, a_b = F_b / m_b;
 *  - water on one side (a hammock, a slab under a pool): the springs carry the load, so the node
 *    moves with its springs implicit, one relaxed block-Jacobi sweep of (M + dt^2 K) a = F per
 *    iteration (a = F / m let the pool through the hammock: 11 crossings in 2 s).
 * The Jacobi diagonal takes 1 / m_b either way (an upper bound of the response: dfsph_factor).
 * The nodes' springs, gravity and contacts stay with the cloth's own step, which takes the fluid's
 * force of the final pressures (Simulation::gatherClothForces). */

/* The fluid around cloth node k on either side of its sheet: the sheet's normal from two of the
 * node's springs (the first pair more than 30 degrees apart), the fluid within H weighed by W on
 * either side of it. Out: (above, below, +-sum_i m_i W_ik (unit: kg/m^3; negative where the node has no
 * normal), 0). Water on both sides (dfsph_node_both_sides): the lesser side has more than `fraction` of
 * the greater. */
inline float4 dfsph_node_sides(const SimParams* p, const uint k, __global const float4* nodes,
                               __global const float4* pos, __global const uint* phase,
                               __global const uint* cell_start, __global const uint* row_start,
                               __global const uint* other) {
  const float4 xk = nodes[k];
  float3 nrm = (float3)(0.0f);
  {
    float3 u0 = (float3)(0.0f);
    for (uint e = row_start[k]; e < row_start[k + 1]; ++e) {
      const float3 d = nodes[other[e]].xyz - xk.xyz;
      const float L = length(d);
      if (L <= 0.0f) continue;
      const float3 u = d / L;
      if (dot(u0, u0) == 0.0f) {
        u0 = u;
        continue;
      }
      const float3 c = cross(u0, u);
      if (length(c) > 0.5f) {
        nrm = normalize(c);
        break;
      }
    }
  }
  const float H = p->support;
  float above = 0.0f, below = 0.0f, mass = 0.0f;
  SPH_FOR_NEIGHBOURS(p, cell_start, xk.xyz, i) {
    const float3 d = pos[i].xyz - xk.xyz;
    const float r2 = dot(d, d);
    if (r2 < H * H) {
      const float w = sph_w(SPH_KERNEL, sqrt(r2), H);
      if (dot(d, nrm) >= 0.0f) above += w; else below += w;
      mass += p->phase_mass[phase[i]] * w;
    }
  }
  SPH_END_NEIGHBOURS
  return (float4)(above, below, dot(nrm, nrm) > 0.0f ? mass : -mass, 0.0f);
}

inline bool dfsph_node_both_sides(const float4 sides, const float fraction) {
  return sides.z > 0.0f && fmin(sides.x, sides.y) > fraction * fmax(sides.x, sides.y);
}

/* Per step: each node's slot gets its response (rows of M_b^-1; w of the first row 1 / m_b for the
 * diagonal, w of the second 1 for a node that moves as its mass) and a zero acceleration; the other
 * slots were zeroed by the host (walls and bodies do not move in the solves). response: cloth.cl's
 * cloth_node_response, the node's mass with its springs implicit (0 anchored), and 1 / (m_b + M_b)
 * with an added mass M_b (dfsph_node_added_mass). */
__kernel void dfsph_node_slots(const SimParams p, const uint n, const uint offset, __global const float4* nodes,
                               __global const float4* response, __global const uint* slot, __global const float4* pos,
                               __global const uint* phase, __global const uint* cell_start,
                               __global const uint* row_start, __global const uint* other,
                               __global float4* bminv, __global float4* bacc) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const uint s = slot[offset + k];
  bacc[s] = (float4)(0.0f);
  const float4 xk = nodes[k];
  /* 1 / m, or 1 / (m + M) with an added mass (cloth_node_response) */
  const float wk = response[3 * k].w > 0.0f ? response[3 * k].w : xk.w;
  if (xk.w != 0.0f && dfsph_node_both_sides(dfsph_node_sides(&p, k, nodes, pos, phase, cell_start, row_start, other), 0.25f)) {
    /* water on both sides: the water's inertia, not the springs, answers the node's motion across
     * the sheet; the node moves as its mass (w of the second row: 1, no spring sweep) */
    bminv[3 * s] = (float4)(wk, 0.0f, 0.0f, wk);
    bminv[3 * s + 1] = (float4)(0.0f, wk, 0.0f, 1.0f);
    bminv[3 * s + 2] = (float4)(0.0f, 0.0f, wk, 0.0f);
    return;
  }
  bminv[3 * s] = (float4)(response[3 * k].xyz, wk); /* w: 1 / m, the diagonal's (dfsph_factor) */
  bminv[3 * s + 1] = (float4)(response[3 * k + 1].xyz, 0.0f);
  bminv[3 * s + 2] = response[3 * k + 2];
}


/* The pressure force of the current pressures on boundary particle b at bb (xyz, w = psi_b), with
 * its wall pressure pb (extrapolated walls; 0 else): F_b = sum_i (wall t_i + pb / delta_i^2) psi_b
 * gradW_ib over the fluid within H (the reaction to dfsph_force's wall terms; t_i = p_i / delta_i^2
 * = xt.w, gradW_ib = F (x_i - x_b)) (unit: N). The fluid comes from the grid of the last list
 * rebuild (its cells hold every neighbour within H, rigid.cl says why). */
inline float3 dfsph_boundary_force(const SimParams* p, const float4 bb, const float pb, __global const float4* xt,
                                   __global const uint* phase, __global const float* density,
                                   __global const uint* cell_start, const float wall) {
  const float3 xb = bb.xyz;
  const float H = p->support;
  float3 F = (float3)(0.0f);
  SPH_FOR_NEIGHBOURS(p, cell_start, xb, i) {
    const float4 x4 = xt[i];
    const float3 d = x4.xyz - xb;
    const float r2 = dot(d, d);
    if (r2 < H * H) {
      const float di = density[i] / p->phase_mass[phase[i]];
      F += ((wall * x4.w + pb / (di * di)) * bb.w * sph_grad_factor(SPH_KERNEL, sqrt(r2), H)) * d;
    }
  }
  SPH_END_NEIGHBOURS
  return F;
}

/* Per iteration: node k's acceleration a_k in the step under the pressure force of the current
 * pressures, F_k = sum_i (wall t_i + use_bp p_b / delta_i^2) psi_b gradW_ib (the reaction to
 * dfsph_force's wall terms; t_i = p_i / delta_i^2 = xt.w, gradW_ib = F (x_i - x_b)). A node that
 * moves as its mass: a_k = F_k / m_k. Else its springs implicit, (M + dt^2 K) a = F over the sheet
 * (M the nodes' masses, K the springs' stiffness: dt c + dt^2 k along a spring, dt^2 T / L across
 * it, as cloth.cl's cloth_node_response), one block-Jacobi sweep per iteration of the pressure
 * solve from the last sweep (nacc_in, kept from step to step), relaxed by 1/2:
 *     a_k = (a_k' + A_k^-1 (F_k + sum_e K_e a_j)) / 2,  A_k = M_k + sum_e K_e (bminv: A_k^-1).
 * w = 1 marks a free node (dfsph_jacobi skips the others). */
__kernel void dfsph_node_accel(const SimParams p, const uint n, const uint offset, __global const float4* nodes,
                               __global const float4* bminv,
                               __global const uint* slot, __global const float4* bpos, __global const float4* xt,
                               __global const uint* phase, __global const float* density,
                               __global const uint* cell_start, const float wall, __global const float* bpr,
                               const int use_bp, __global const uint* row_start, __global const uint* spring,
                               __global const uint* other, __global const float4* prm,
                               __global const uint* broken, __global const float4* nacc_in,
                               __global float4* nacc_out, __global float4* bacc) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const float4 xk = nodes[k];
  const uint s = slot[offset + k];
  if (xk.w == 0.0f) { /* anchored: stays (0, 0, 0, 0) from dfsph_node_slots */
    nacc_out[k] = (float4)(0.0f);
    return;
  }
  float3 F = dfsph_boundary_force(&p, bpos[s], use_bp ? bpr[s] : 0.0f, xt, phase, density, cell_start, wall);
  /* the springs: sum_e K_e a_j, K_e = ax u u^T + tr (I - u u^T) (none for a node moving as its mass) */
  const float dt = p.dt;
  const bool free_node = bminv[3 * s + 1].w != 0.0f;
  const uint end = free_node ? row_start[k] : row_start[k + 1];
  for (uint e = row_start[k]; e < end; ++e) {
    const uint sp = spring[e];
    if (broken[sp]) continue;
    const uint j = other[e];
    const float3 d = nodes[j].xyz - xk.xyz;
    const float L = length(d);
    if (L <= 0.0f) continue;
    const float3 u = d / L;
    const float4 q = prm[sp];
    const float2 K = cloth_spring_step_stiffness(q, L, dt); /* along, across (shared/cloth_springs.h) */
    const float ax = K.x, tr = K.y;
    const float3 aj = nacc_in[j].xyz;
    F += tr * aj + (ax - tr) * dot(u, aj) * u;
  }
  const float3 a = free_node ? bminv[3 * s].x * F : 0.5f * (nacc_in[k].xyz + dfsph_mul3(bminv, s, F));
  nacc_out[k] = (float4)(a, 0.0f);
  bacc[s] = (float4)(a, 1.0f);
}

/* DFSPH's added mass of wet cloth nodes (Simulation::clothAddedMass), before the step's solves. Per
 * node k: sigma_k = sum_i m_i W(|x_i - x_k|) over the fluid within H (dfsph_node_sides; unit: kg/m^3);
 * the added mass of a free node M_k = c_rho_v0 psi_k min(1, sigma_k / wet_rho) (c_rho_v0 psi_k = C rho0
 * V_k, V_k = psi_k V0 the volume its boundary particle stands for; wet_rho a tenth of rho0: a node in
 * water has the whole of it, one touched by a few drops little, so that a splash's particles do not
 * take a whole node's reaction), 0 for an anchored node, an explicit cloth's (its step has no added
 * mass) or with c_rho_v0 = 0; and the share J_k / s_k,
 * s_k = psi_k sigma_k, of the momentum J_k = M_k (v' - v) the node's added mass took
 * (cloth_added_mass_impulse), which dfsph_node_added_mass_reaction gives the fluid (as rigid.cl's
 * (4a)-(4c) give a body's fictitious force's); J_k is then cleared, or kept while the node has no
 * fluid within H. */
__kernel void dfsph_node_added_mass(const SimParams p, const uint n, const uint offset, __global const float4* nodes,
                                    __global const float4* bsrc, __global const float4* pos,
                                    __global const uint* phase, __global const uint* cell_start,
                                    __global const uint* row_start, __global const uint* other,
                                    __global const uint* is_xpbd, const float c_rho_v0, const float wet_rho,
                                    __global float4* impulse,
                                    __global float* fict,
                                    __global float4* share) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const float psi = bsrc[offset + k].w;
  const float4 sides = dfsph_node_sides(&p, k, nodes, pos, phase, cell_start, row_start, other);
  const float s = psi * fabs(sides.z);
  if (s > 0.0f) {
    share[k] = impulse[k] / s;
    impulse[k] = (float4)(0.0f);
  } else {
    share[k] = (float4)(0.0f);
  }
  fict[k] = nodes[k].w != 0.0f && is_xpbd[k] ? c_rho_v0 * psi * fmin(1.0f, fabs(sides.z) / wet_rho) : 0.0f;
}

/* Each fluid particle i: v_i += sum over its boundary neighbours k within H that are cloth nodes of
 * psi_k W_ik share_k, so that sum_i m_i dv_i = sum_k J_k (the pairs are those of
 * dfsph_node_added_mass: the lists hold every pair within H at the step's start). */
__kernel void dfsph_node_added_mass_reaction(const SimParams p, const uint offset, const uint n_nodes,
                                             __global const float4* pos, __global const float4* bpos,
                                             __global const uint* sbnbr, __global const uint* sbnbr_count,
                                             __global const uint* sorted, __global const float4* share,
                                             __global float4* vel) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 dv = sph_boundary_share_dv(&p, i, pos, bpos, sbnbr, sbnbr_count, sorted, offset, n_nodes, 0, share);
  const uint nb = sbnbr_count[i];
  if (nb > 0) vel[i] = (float4)(vel[i].xyz + dv, vel[i].w);
}

/* Before the density solve: each free node's acceleration a_b (the divergence solve's, in bacc) gains
 * what the cloth's own forces do in the step, dv / dt (ClothSim::dryVelocityChange: gravity, springs,
 * anchors, balls), so that the density solve sees the nodes move as the step will move them. */
__kernel void dfsph_node_dry(const uint n, const uint offset, const float inv_dt, __global const float4* nodes,
                             __global const uint* slot, __global const float4* dv, __global float4* bacc) {
  const uint k = get_global_id(0);
  if (k >= n || nodes[k].w == 0.0f) return;
  const uint s = slot[offset + k];
  bacc[s] = (float4)(bacc[s].xyz + inv_dt * dv[k].xyz, bacc[s].w);
}

/* Before the density solve: the nodes move on by dt a_b in the density solve's eyes (the cloth's
 * step applies both solves' forces): gwall_i.w = sum_b psi_b v_b . gradW_ib gains dt sum_b psi_b
 * a_b . gradW_ib (a_b: the divergence solve's final pressures' (dfsph_node_accel), plus the cloth's
 * own forces' (dfsph_node_dry)). */
__kernel void dfsph_node_rate(const SimParams p, __global const float4* pos, __global const float4* bpos,
                              __global const uint* bnbr, __global const uint* bnbr_count,
                              __global const float4* bacc, __global float4* gwall) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float add = dfsph_node_sum(pos[i].xyz, bnbr + (size_t)i * K, bnbr_count[i], bpos, bacc, p.support);
  if (add != 0.0f) gwall[i].w += p.dt * add;
}

/* --- Rigid bodies inside the solves (fluid.dfsph.body_coupling: strong) ---------------------------
 * Gissler et al. 2019 (Interlinked SPH pressure solvers for strong fluid-rigid coupling, ACM TOG
 * 38(1) 5) move each rigid body under the pressures inside the solver's iterations, so that fluid
 * and body meet the density constraint together. Here the body's particles are boundary particles
 * that move in the solves as the cloth nodes do (their slot's acceleration in bacc, w = 1; the
 * residual of dfsph_jacobi and the density rate of dfsph_node_rate count it), their acceleration
 * that of the whole body:
 *     a_k = a + alpha x (x_k - c),   a = F / m,   alpha = I^-1 T,
 * F and T the pressure force and torque of the current pressures on all the body's particles.
 * Per iteration, three gathers: (a) dfsph_body_force, each body particle's force; (b)
 * dfsph_body_accel, per body, F and T summed in particle order (a fixed order: deterministic) and
 * the acceleration relaxed by 1/2 against the last iteration's (a body lighter than the water
 * around it answers a pressure more than one fluid layer does, and the plain update would
 * overshoot; the fixed point is the same); (c) dfsph_body_slots, each particle's slot. The gyroscopic
 * term w x I w is left to the body's own step. body data: DFSPH_BODY_STRIDE float4 per moving body
 * (kernels/shared/body_response.h): the centre, whether it moves in the solves, its acceleration
 * without the fluid's pressure, and its mobility N ((a, alpha) = N (F, T); diag(1 / m, I_w^-1) for
 * a free body, a held one's with its grab implicit). */

/* (a) The pressure force of the current pressures on moving particle k (unit: N). */
__kernel void dfsph_body_force(const SimParams p, const uint n, const uint n_static, __global const float4* bsrc,
                               __global const uint* slot, __global const float* bpr, const int use_bp,
                               __global const float4* xt, __global const uint* phase,
                               __global const float* density, __global const uint* cell_start, const float wall,
                               __global float4* force) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const float pb = use_bp ? bpr[slot[n_static + k]] : 0.0f;
  force[k] = (float4)(dfsph_boundary_force(&p, bsrc[n_static + k], pb, xt, phase, density, cell_start, wall), 0.0f);
}

/* (b) Per body b (particles range[2b] .. range[2b] + range[2b+1] - 1): acc[2b] = a, acc[2b+1] = alpha
 * (unit: m/s^2, 1/s^2), relaxed: acc <- relax N (F, T) + (1 - relax) acc; and the body's error
 * err[b] = |N_a (F, T) - a| + R |N_alpha (F, T) - alpha| (N the mobility, R the body's reach) (unit: m/s^2): how far
 * the acceleration the fluid saw is from the one its pressures give. The solve goes on while a body's
 * error is above fluid.dfsph.body_error: the average density error alone stops before the smooth
 * pressure mode about a body has converged (a floating block's force swung with period 2 steps,
 * 3.3 N standard deviation for its 4.2 N weight, when its density solve stopped at 6 iterations;
 * 0.10 N at 20; docs/forces.md, session 23). */
__kernel void dfsph_body_accel(const uint n_bodies, const uint n_static, __global const uint* range,
                               __global const float4* bsrc, __global const float4* data,
                               __global const float4* force, const float relax, __global float4* acc,
                               __global float* err) {
  const uint b = get_global_id(0);
  if (b >= n_bodies) return;
  const float4 c4 = data[DFSPH_BODY_STRIDE * b];
  if (c4.w == 0.0f) {
    acc[2 * b] = acc[2 * b + 1] = (float4)(0.0f);
    err[b] = 0.0f;
    return;
  }
  float3 F = (float3)(0.0f), T = (float3)(0.0f);
  const uint begin = range[2 * b], end = begin + range[2 * b + 1];
  for (uint k = begin; k < end; ++k) {
    const float3 f = force[k].xyz;
    F += f;
    T += cross(bsrc[n_static + k].xyz - c4.xyz, f);
  }
  float3 a, al;
  dfsph_body_mobility(data, b, F, T, &a, &al);
  err[b] = length(a - acc[2 * b].xyz) + data[DFSPH_BODY_STRIDE * b + 1].w * length(al - acc[2 * b + 1].xyz);
  acc[2 * b] = (float4)(relax * a + (1.0f - relax) * acc[2 * b].xyz, 0.0f);
  acc[2 * b + 1] = (float4)(relax * al + (1.0f - relax) * acc[2 * b + 1].xyz, 0.0f);
}

/* (c) Each moving particle k of a body that moves in the solves: its slot's acceleration
 * a + alpha x r (w = 1), with `dry` the body's own (data rows 4, 5) added: before the density
 * solve, whose density rate counts the motion of the whole step (dfsph_node_rate). */
__kernel void dfsph_body_slots(const uint n, const uint n_static, __global const uint* body,
                               __global const uint* slot, __global const float4* bsrc, __global const float4* data,
                               __global const float4* acc, const int dry, __global float4* bacc) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const uint b = body[k];
  const float4 c4 = data[DFSPH_BODY_STRIDE * b];
  const uint s = slot[n_static + k];
  if (c4.w == 0.0f) {
    bacc[s] = (float4)(0.0f);
    return;
  }
  float3 a = acc[2 * b].xyz, al = acc[2 * b + 1].xyz;
  if (dry) a += data[DFSPH_BODY_STRIDE * b + 1].xyz, al += data[DFSPH_BODY_STRIDE * b + 2].xyz;
  bacc[s] = (float4)(a + cross(al, bsrc[n_static + k].xyz - c4.xyz), 1.0f);
}

