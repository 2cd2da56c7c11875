/* DFSPH two-level solve: a coarse-grid correction of the pressures, all on the device (stages:
 * divergence_solve, density_solve; solver dfsph with fluid.dfsph.coarse_interval > 0; host side
 * core/dfsph_coarse.cpp, DfsphSolver::coarseCorrection, which only enqueues these kernels).
 *
 * Why: the Jacobi iteration of dfsph.cl (r = s - A p, p += omega r alpha / (dt^2 V0)) removes an
 * error of wavelength L only in ~(L / dx)^2 iterations, and the solve stops on the average error
 * eta; a pressure error smooth over a column of depth H changes the density over a step by only
 * dt^2 dp (pi / 2H)^2 / rho0, so up to dp_eta = rho0 eta (2H / pi)^2 / dt^2 passes unseen and the
 * column rings within it (docs/dfsph.md). A two-level method (Briggs, Henson & McCormick 2000,
 * "A Multigrid Tutorial", ch. 3 and 5: smoothing plus coarse-grid correction; Vanek, Mandel &
 * Brezina 1996: aggregation) solves the smooth part on aggregates instead:
 *
 *   aggregates: the fluid particles in one cell of size H (the kernel support) of cells aligned
 *   with the domain box (so that a particle lattice filling the box, dx = H / 2, gives whole
 *   aggregates of 2 x 2 x 2; the neighbour grid's cells, H + skin wide, gave aggregates one layer
 *   thin at walls and the tank rang by 1.3 kPa), only the particles in the active set of the
 *   complementarity problem (p_i > 0 or r_i > 0; the divergence solve's free-surface particles
 *   with too few neighbours are out); a cell with fewer than 4 active particles is no aggregate
 *   (slivers at a free surface or a wall, splashes: their one-row Galerkin entries are nearly
 *   singular). The particles of an aggregate are found through the neighbour grid (sorted by its
 *   cells at the last list build, none moved more than skin / 2 since), in grid order;
 *   prolongation P: piecewise constant, (P e)_i = e_c(i) (unit: Pa);
 *   Galerkin coarse operator K = -P^T A P, from the same pair terms as the Jacobi pass:
 *       K_dc = dt^2 V0 sum_i F_i(c) . R_i(d),
 *       F_i(c) = (1/m_i) [ sum_j ([i in c] / delta_i^2 + [j in c] / delta_j^2) gradW_ij
 *                          + w [i in c] / delta_i^2 G_b,i ]     (minus the acceleration of i from
 *                                                              a unit pressure on aggregate c),
 *       R_i(d) = sum_j ([i in d] + [j in d]) gradW_ij + [i in d] G_b,i
 *       (sum_{k in d} (D a)_k = sum_i a_i . R_i(d) for D a the density change of dfsph_jacobi,
 *       by the antisymmetry of gradW_ij), G_b,i the factor pass's wall sum (gwall); w = 2 with
 *       extrapolated walls: the extrapolated wall pressure of a smooth field is that of the fluid
 *       next to it (p_b = p_i, mirrored), w = 1 with single walls (p_b = 0). F leaves out the part of
 *       G_b,i from free cloth nodes with water on both sides (session 21): the solve moves them as
 *       free masses within it (dfsph_node_accel), and their extrapolated pressure is the average of
 *       both sides', so a wall's mirrored push over-predicts the sheet's response by ~2x (the line
 *       search's theta 0.46-0.49 in the paper's demo and the sealed sandwich). Measured, with
 *       that node term in F weighted 2 / 1.5 / 1 / 0: the demo's 2 s in 10,966 / 10,150 / 8,833 /
 *       8,284 density iterations, 1,406 / 1,239 / 952 / 798 corrections; 0 is the fastest (0.67x
 *       the time of 2, medians of 3; docs/dfsph.md, session 21). A neighbour within H
 *       of i lies in i's aggregate cell or the next one, so K couples aggregates up to two cells
 *       apart: a 125-point stencil per row;
 *   coarse solve: BiCGStab with a Jacobi preconditioner (van der Vorst 1992; Saad 2003, "Iterative
 *   Methods for Sparse Linear Systems", Alg. 7.7) in one work-group, until the residual is below
 *   1e-4 of P^T r (2-norm) or after 100 iterations (core/dfsph_coarse.cpp). K is symmetric but for
 *   the walls' w and the densities (F weighs by 1 / delta^2, R does not): 5 % of its norm in the
 *   sealed column and the paper's demo, whose K's symmetric part even has a negative eigenvalue.
 *   Conjugate gradients (sessions 10-20) converged on the tank (13-49 iterations to 1e-4; BiCGStab
 *   ~20, session 21) but stalled in the demo: 100 of 100 iterations, the residual left at 4e-3
 *   (measured, session 20; in double precision on the same K, 3.4e-3 after 1000), where BiCGStab
 *   reaches 1e-4 in 30 (two products with K each). Not kept: CG on the symmetric part (K + K^T) / 2
 *   (the tank rang until 1.25-1.5 s, 1 kPa between steps at 1-1.25 s, against < 1 Pa); CG on a Gram
 *   form sum_i B_i(c) . B_i(d) / m_i with 1 / delta weights on both sides, symmetric positive
 *   semi-definite and equal to K where the density is uniform (the resting tank rang by 1 kPa,
 *   session 21);
 *   correction: q = P e scaled by the line search theta = -<q, r> / <q, dr> (dr: the residual
 *   change q makes with the walls' own operator, dfsph_coarse_trial), within [0, 2], and
 *   p_i <- max(p_i + theta q_i, 0) for the active particles (the projection of dfsph_jacobi).
 *
 * Every sum runs in a fixed order (particles in index order within a cell, cells in grid order,
 * work-group reductions over a fixed tree, chunks in order): bitwise deterministic, no float
 * atomics, and nothing crosses to the host. */

/* Work-group size of the single-group kernels (numbering, the coarse solve). */
#define DFSPH_COARSE_WG 256

/* Box coordinates of an aggregate cell index (cells of size H from domain_min, box dims bd). */
inline int3 dfsph_coarse_coords(const int4 bd, const uint c) {
  return (int3)((int)(c % (uint)bd.x), (int)((c / (uint)bd.x) % (uint)bd.y), (int)(c / (uint)(bd.x * bd.y)));
}

/* Slot 0..26 of a cell offset within one cell, (ox + 1) * 9 + (oy + 1) * 3 + (oz + 1). */
inline int dfsph_coarse_slot(const int3 o) { return (o.x + 1) * 9 + (o.y + 1) * 3 + (o.z + 1); }

/* The particles whose aggregate cells may lie within `reach` cells of aggregate cell c: the
 * neighbour-grid cells (at the last list build) overlapping c's box grown by reach H + skin / 2,
 * as ranges of sorted particles per grid row [BEGIN, END), in grid order. */
#define DFSPH_COARSE_FOR_ROWS(P, CELL_START, C, REACH, BEGIN, END)                                     \
  {                                                                                                     \
    const float H_ = (P)->support, grow_ = (REACH) * H_ + 0.5f * ((P)->cell_size - H_) + 1e-6f;         \
    const float3 dmin_ = (float3)((P)->domain_min[0], (P)->domain_min[1], (P)->domain_min[2]);          \
    const float3 lo_ = dmin_ + convert_float3(C) * H_ - grow_, hi_ = dmin_ + convert_float3(C + 1) * H_ + grow_; \
    const int3 ga_ = sph_cell_of(P, lo_), gb_ = sph_cell_of(P, hi_);                                    \
    for (int z_ = ga_.z; z_ <= gb_.z; ++z_)                                                              \
      for (int y_ = ga_.y; y_ <= gb_.y; ++y_) {                                                          \
        const uint row_ = (uint)((P)->grid_dims[0] * (y_ + (P)->grid_dims[1] * z_));                    \
        const uint BEGIN = CELL_START[row_ + (uint)ga_.x];                                               \
        const uint END = min(CELL_START[row_ + (uint)gb_.x + 1u], (P)->n_fluid);

#define DFSPH_COARSE_END_ROWS \
  }                           \
  }

/* Aggregate cell of each particle: floor((x - domain_min) / H), clamped to the box (a particle
 * outside an open wall joins the edge cell). */
__kernel void dfsph_coarse_cells(const SimParams p, const int4 bd, __global const float4* pos, __global uint* agg) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 d = (pos[i].xyz - (float3)(p.domain_min[0], p.domain_min[1], p.domain_min[2])) / p.support;
  const int3 c = clamp(convert_int3_rtn(d), (int3)(0), (int3)(bd.x - 1, bd.y - 1, bd.z - 1));
  agg[i] = (uint)(c.x + bd.x * (c.y + bd.y * c.z));
}

/* The residual of the current pressures r_i = s_i + dt^2 V0 (sum_j (a_i - a_j) . gradW_ij + a_i . G_b)
 * (dfsph_jacobi's, for accel = a^p(p) from dfsph_pressure_accel) and whether particle i is in the
 * active set (act = 1): p_i > 0 or r_i > 0, and (divergence solve) enough neighbours. `trial` (the
 * line search's): the residual alone into res, no active set. `bodies` (fluid.dfsph.body_coarse): the
 * free bodies' particles' accelerations in the solve count too, - dt^2 V0 sum_b psi_b a_b . gradW_ib
 * over the boundary particles b of a free body (sbody[b] >= 0; bacc, dfsph_body_slots), as in
 * dfsph_jacobi; the cloth nodes' are left out (the correction does not move them). */
__kernel void dfsph_coarse_residual(const SimParams p, __global const float4* pos, __global const float4* accel,
                                    __global const float* source, __global const uint* nbr,
                                    __global const uint* nbr_count, __global const uint* bnbr_count,
                                    const uint min_neighbours, __global const float* pressure,
                                    __global const float4* gwall, const int trial, __global float* res,
                                    __global int* act, const int bodies, __global const int* sbody,
                                    __global const float4* bpos, __global const uint* bnbr,
                                    __global const float4* bacc) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float H = p.support;
  const float3 xi = pos[i].xyz, ai = accel[i].xyz;
  const uint nf = nbr_count[i];
  const SphList list = sph_list(&p, nbr, i); /* narrow or wide (shared/neighbours.h) */
  float Ap = 0.0f;
  for (uint k = 0; k < nf; ++k) {
    const uint j = sph_list1(list, k);
    const float3 d = xi - pos[j].xyz;
    Ap += sph_grad_factor(SPH_KERNEL, length(d), H) * dot(ai - accel[j].xyz, d);
  }
  Ap += dot(ai, gwall[i].xyz);
  if (bodies) {
    __global const uint* bl = bnbr + (size_t)i * K;
    const uint nb = bnbr_count[i];
    for (uint q = 0; q < nb; ++q) {
      const uint b = bl[q];
      if (sbody[b] < 0) continue;
      const float4 bb = bpos[b];
      const float3 d = xi - bb.xyz;
      Ap -= bb.w * sph_grad_factor(SPH_KERNEL, length(d), H) * dot(bacc[b].xyz, d);
    }
  }
  const float r = source[i] + p.dt * p.dt * p.rest_volume * Ap;
  res[i] = r;
  if (trial) return;
  act[i] = (nf + bnbr_count[i] >= min_neighbours) && (pressure[i] > 0.0f || r > 0.0f);
}

/* Per aggregate cell of the box: its active particles' count and residual sum (P^T r, in grid
 * order); the cell is an aggregate when it holds at least 4 of them. */
__kernel void dfsph_coarse_aggregate(const SimParams p, const int4 bd, __global const uint* cell_start,
                                     __global const uint* agg, __global const int* act, __global const float* res,
                                     __global int* box_ok, __global float* box_b) {
  /* cells spread over the work-groups (as the rows of dfsph_coarse_assemble: the fluid fills the
   * box's lower cells) */
  const uint c = get_local_id(0) * get_num_groups(0) + get_group_id(0);
  if (c >= (uint)bd.w) return;
  const int3 cc = dfsph_coarse_coords(bd, c);
  int count = 0;
  float s = 0.0f;
  DFSPH_COARSE_FOR_ROWS(&p, cell_start, cc, 0.0f, begin, end)
  for (uint k = begin; k < end; ++k)
    if (agg[k] == c && act[k]) ++count, s += res[k];
  DFSPH_COARSE_END_ROWS
  box_ok[c] = count >= 4;
  box_b[c] = s;
}

/* Sum of one value (T: float, or float8 for the bodies' six sums) per work-item over the work-group,
 * in a fixed tree (deterministic). Every work-item gets the sum. */
#define DFSPH_COARSE_GROUP_SUM(NAME, T)        \
  inline T NAME(__local T* red, const T v) {   \
    const uint l = get_local_id(0);            \
    red[l] = v;                                \
    barrier(CLK_LOCAL_MEM_FENCE);              \
    for (uint s = DFSPH_COARSE_WG / 2; s > 0; s >>= 1) { \
      if (l < s) red[l] += red[l + s];         \
      barrier(CLK_LOCAL_MEM_FENCE);            \
    }                                          \
    const T out = red[0];                      \
    barrier(CLK_LOCAL_MEM_FENCE);              \
    return out;                                \
  }
DFSPH_COARSE_GROUP_SUM(dfsph_coarse_group_sum, float)
DFSPH_COARSE_GROUP_SUM(dfsph_coarse_group_sum8, float8)

/* Number the aggregates in box order (one work-group; a prefix sum per block of cells in local
 * memory): num[c] = the aggregate's number of box cell c, -1 where c is no aggregate; cell[k] the
 * box cell of aggregate k, b (the right-hand side P^T r) and the count m in mcount[0]. */
__kernel __attribute__((reqd_work_group_size(DFSPH_COARSE_WG, 1, 1)))
void dfsph_coarse_number(const int4 bd, const uint rows, __global const int* box_ok, __global const float* box_b,
                         __global int* num, __global uint* cell, __global float* b, __global uint* mcount) {
  __local uint scan[DFSPH_COARSE_WG];
  const uint l = get_local_id(0);
  const uint n = (uint)bd.w;
  uint base = 0;
  for (uint start = 0; start < n; start += DFSPH_COARSE_WG) {
    const uint c = start + l;
    const uint flag = c < n && box_ok[c] ? 1u : 0u;
    /* inclusive scan of the flags (Hillis & Steele 1986) */
    scan[l] = flag;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint off = 1; off < DFSPH_COARSE_WG; off <<= 1) {
      const uint v = l >= off ? scan[l - off] : 0u;
      barrier(CLK_LOCAL_MEM_FENCE);
      scan[l] += v;
      barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (c < n) {
      const uint k = base + scan[l] - flag;
      const int ok = flag && k < rows; /* at most `rows` aggregates (4 active particles each) */
      num[c] = ok ? (int)k : -1;
      if (ok) cell[k] = c, b[k] = box_b[c];
    }
    base += scan[DFSPH_COARSE_WG - 1];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (l == 0) mcount[0] = min(base, rows);
}

/* A reused operator (core/dfsph_coarse.cpp, fluid.dfsph.coarse_reuse): the right-hand side P^T r
 * of the aggregates numbered when it was assembled, b[k] = box_b[cell[k]] (the cell's active
 * particles' residual sum now). */
__kernel void dfsph_coarse_rhs(__global const uint* mcount, __global const uint* cell, __global const float* box_b,
                               __global float* b) {
  const uint k = get_global_id(0);
  if (k >= mcount[0]) return;
  b[k] = box_b[cell[k]];
}

/* Each particle's aggregate number when it is active and its cell an aggregate, else -1. */
__kernel void dfsph_coarse_members(const SimParams p, __global const uint* agg, __global const int* act,
                                   __global const int* num, __global int* mem) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  mem[i] = act[i] ? num[agg[i]] : -1;
}

/* Per particle i and per aggregate of its 3 x 3 x 3 cell neighbourhood (slot dfsph_coarse_slot of
 * the aggregate's cell offset): F_i(c) (unit: m^2/kg) and R_i(d) (unit: 1/m^4) of the top of this
 * file, fr[(i * 27 + slot) * 2] = F, fr[... + 1] = R; only the non-zero slots are written, and
 * mask = (F slots, R slots) says which. */
__kernel void dfsph_coarse_pairs(const SimParams p, const int4 bd, __global const float4* pos, __global const uint* phase,
                                 __global const float* density, __global const uint* nbr,
                                 __global const uint* nbr_count, __global const float4* gwall,
                                 __global const uint* agg, __global const int* mem, const float wall,
                                 __global float4* fr, __global uint2* mask, __global const float4* bpos,
                                 __global const uint* bnbr, __global const uint* bnbr_count, const int nodes,
                                 __global const float4* bminv) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint K = p.max_neighbours;
  const float H = p.support;
  const float3 xi = pos[i].xyz;
  const float mi = p.phase_mass[phase[i]];
  const float di = density[i] / mi;
  const int3 ci = dfsph_coarse_coords(bd, agg[i]);
  float3 F[27], R[27];
  for (int s = 0; s < 27; ++s) F[s] = R[s] = (float3)(0.0f);
  uint fm = 0, rm = 0;
  const uint nf = nbr_count[i];
  const SphList list = sph_list(&p, nbr, i); /* narrow or wide (shared/neighbours.h) */
  float3 gsum = (float3)(0.0f);
  for (uint k = 0; k < nf; ++k) {
    const uint j = sph_list1(list, k);
    const float3 d = xi - pos[j].xyz;
    const float3 g = sph_grad_factor(SPH_KERNEL, length(d), H) * d;
    gsum += g;
    /* the neighbour's aggregate: the terms with [j in c], when j is a member */
    if (mem[j] < 0) continue;
    const int3 o = dfsph_coarse_coords(bd, agg[j]) - ci;
    if (abs(o.x) > 1 || abs(o.y) > 1 || abs(o.z) > 1) continue; /* within H: cannot happen */
    const int s = dfsph_coarse_slot(o);
    const float dj = density[j] / p.phase_mass[phase[j]];
    F[s] += g / (dj * dj);
    R[s] += g;
    fm |= 1u << s;
    rm |= 1u << s;
  }
  /* i's own aggregate (slot 13): the terms with [i in c], when i is a member */
  if (mem[i] >= 0) {
    const float3 gb = gwall[i].xyz;
    /* the free cloth nodes with water on both sides (dfsph_node_slots' mark: bminv w of the second
     * row): their wall sum leaves the force term (session 21: the top of this file) */
    float3 gbn = (float3)(0.0f);
    if (nodes) {
      __global const uint* bl = bnbr + (size_t)i * K;
      const uint nbb = bnbr_count[i];
      for (uint q = 0; q < nbb; ++q) {
        const uint b = bl[q];
        if (bminv[3 * b + 1].w == 0.0f) continue;
        const float4 bb = bpos[b];
        const float3 d = xi - bb.xyz;
        gbn += (bb.w * sph_grad_factor(SPH_KERNEL, length(d), H)) * d;
      }
    }
    F[13] += (gsum + wall * (gb - gbn)) / (di * di);
    R[13] += gsum + gb;
    fm |= 1u << 13;
    rm |= 1u << 13;
  }
  __global float4* out = fr + (size_t)i * 54;
  for (int s = 0; s < 27; ++s) {
    if (fm & (1u << s)) out[2 * s] = (float4)(F[s] / mi, 0.0f);
    if (rm & (1u << s)) out[2 * s + 1] = (float4)(R[s], 0.0f);
  }
  mask[i] = (uint2)(fm, rm);
}

/* Row d of K per aggregate: K_dc = scale sum_i F_i(c) . R_i(d) over the particles i whose aggregate
 * cell is within one of d's (in grid order, each grid cell's particles in index order), into 125
 * slots by the offset of c from d (kval, (m x 125); unit: m^3 s^2/kg, scale = dt^2 V0) with the
 * column's aggregate number (kcol, -1: none). */
__kernel void dfsph_coarse_assemble(const SimParams p, const int4 bd, __global const uint* cell_start,
                                    __global const uint* agg, __global const uint* mcount, __global const uint* cell,
                                    __global const int* num, __global const float4* fr, __global const uint2* mask,
                                    const float scale, __global float* kval, __global int* kcol) {
  /* rows spread over the work-groups in contiguous runs: group g takes rows g B .. g B + B - 1, B =
   * ceil(m / G) (G groups, m aggregates). The launch covers the most rows there can be, but the
   * aggregates found are numbered from 0, so `d = global id` left every row in the first groups and,
   * on a CPU that hands each thread a run of consecutive work-groups, all the work on one thread
   * (measured, session 20). Session 20's spread (rows g, g + G, g + 2 G, ...) gave a group rows far
   * apart; in a run, neighbouring rows (box order: x fastest) read mostly the same particles' terms,
   * which then stay in the cache (sessions 43-44). */
  const uint m = mcount[0];
  const uint per = (m + get_num_groups(0) - 1u) / get_num_groups(0);
  if (get_local_id(0) >= per) return;
  const uint d = get_group_id(0) * per + get_local_id(0);
  if (d >= m) return;
  const int3 cd = dfsph_coarse_coords(bd, cell[d]);
  float row[125];
  for (int o = 0; o < 125; ++o) row[o] = 0.0f;
  DFSPH_COARSE_FOR_ROWS(&p, cell_start, cd, 1.0f, begin, end)
  for (uint k = begin; k < end; ++k) {
    const uint2 mk = mask[k];
    if (!mk.y) continue;
    const int3 ck = dfsph_coarse_coords(bd, agg[k]);
    const int3 od = cd - ck;
    if (abs(od.x) > 1 || abs(od.y) > 1 || abs(od.z) > 1) continue;
    const int sd = dfsph_coarse_slot(od);
    if (!(mk.y & (1u << sd))) continue;
    const float3 Rk = fr[(size_t)k * 54 + 2 * sd + 1].xyz;
    /* F_k(c) for each aggregate c next to k: offset c - d = (ck + o_s) - cd in [-2, 2]^3; the
     * non-zero slots in ascending order, lowest set bit first (~8 of 27) */
    for (uint bits = mk.x; bits != 0u; bits &= bits - 1u) {
      const int s = 31 - (int)clz(bits & (~bits + 1u));
      const int3 oc = ck + (int3)(s / 9 - 1, (s / 3) % 3 - 1, s % 3 - 1) - cd;
      const int o = (oc.x + 2) * 25 + (oc.y + 2) * 5 + (oc.z + 2);
      row[o] += dot(fr[(size_t)k * 54 + 2 * s].xyz, Rk);
    }
  }
  DFSPH_COARSE_END_ROWS
  /* the columns' aggregates */
  __global float* kv = kval + (size_t)d * 125;
  __global int* kc = kcol + (size_t)d * 125;
  for (int o = 0; o < 125; ++o) {
    const int3 c = cd + (int3)(o / 25 - 2, (o / 5) % 5 - 2, o % 5 - 2);
    int col = -1;
    if (c.x >= 0 && c.y >= 0 && c.z >= 0 && c.x < bd.x && c.y < bd.y && c.z < bd.z)
      col = num[c.x + bd.x * (c.y + bd.y * c.z)];
    kc[o] = col;
    kv[o] = col >= 0 ? scale * row[o] : 0.0f;
  }
}

/* --- Free bodies in the coarse system (fluid.dfsph.body_coarse, with body_coupling strong) ---------
 * The Jacobi residual counts the moving boundary particles (dfsph_jacobi): with a_b = A + alpha x
 * (x_b - c) for a particle b of body B (c its centre),
 *     dr_i = - dt^2 V0 sum_{b in B} psi_b a_b . gradW_ib = - dt^2 V0 w_i^B . (A, alpha),
 *     w_i^B = sum_{b in B} psi_b [gradW_ib ; (x_b - c) x gradW_ib]   ((alpha x r) . g = alpha . (r x g)),
 * and a pressure change q on the fluid changes the body's force and torque (dfsph_boundary_force, with
 * the extrapolated wall pressure of a smooth field taken as the fluid's: weight `wall` = 2, single 1)
 * by V^B^T q = sum_i (wall / delta_i^2) q_i w_i^B. The body then moves by M_B^-1 V^B^T q (M_B = diag(m,
 * I)). A correction that leaves the bodies held (K e = P^T r) is the wrong coarse problem for a free
 * body: with a light one (its added mass above its mass) the correction and the body's update in the
 * iterations are a block Gauss-Seidel pair that converges only under relaxation (docs/forces.md, session
 * 24). The coupled one, with the bodies at a = M^-1 F(p) before it (so the body's own equation holds):
 *     P^T (r + A P e + U M^-1 V^T P e) = 0,   U_d^B = - dt^2 V0 sum_{i in d} w_i^B,
 *     (K + sum_B dt^2 V0 W^B M_B^-1 V^B^T) e = P^T r,   W_d^B = sum_{i in d} w_i^B,  V_d^B = sum_{i in d} (wall / delta_i^2) w_i^B:
 * a rank-6 term per body (the Schur complement of the bodies' block), added in the BiCGStab's product
 * (dfsph_coarse_matvec): per body six group sums s = V^B^T v, then y_d += dt^2 V0 W_d^B . M_B^-1 s.
 * (Gissler et al. 2019 couple the bodies to the fine pressure solve; this is the same coupling on the
 * coarse level.) */

/* Each boundary slot's free body (body_coupling strong, kernels/shared/body_response.h: free), -1 for the
 * rest (filled by the host first): sbody[slot[n_static + k]] for each moving particle k. */
__kernel void dfsph_coarse_slot_body(const uint n, const uint n_static, __global const uint* body,
                                     __global const uint* slot, __global const float4* data, __global int* sbody) {
  const uint k = get_global_id(0);
  if (k >= n) return;
  const uint b = body[k];
  if (data[DFSPH_BODY_STRIDE * b].w != 0.0f) sbody[slot[n_static + k]] = (int)b;
}

/* Per aggregate d and free body B: cwv[(d n_bodies + B) 4 + 0..3] = (scale W_d^B's translation and
 * rotation parts, V_d^B's) of the comment above, scale = dt^2 V0: the residual per unit acceleration
 * (unit: s^2/m, s^2) and the force and torque per unit pressure (unit: m^2, m^3); the members i of d in
 * grid order, each one's boundary list in its order. */
__kernel void dfsph_coarse_bodies(const SimParams p, const int4 bd, __global const uint* cell_start,
                                  __global const uint* mcount, __global const uint* cell, __global const int* mem,
                                  __global const float4* pos, __global const uint* phase,
                                  __global const float* density, __global const float4* bpos,
                                  __global const uint* bnbr, __global const uint* bnbr_count,
                                  __global const int* sbody, __global const float4* data, const uint n_bodies,
                                  const float wall, const float scale, __global float4* cwv) {
  /* rows spread over the work-groups, as dfsph_coarse_assemble's */
  const uint d = get_local_id(0) * get_num_groups(0) + get_group_id(0);
  if (d >= mcount[0]) return;
  const uint K = p.max_neighbours;
  const float H = p.support;
  const int3 cd = dfsph_coarse_coords(bd, cell[d]);
  for (uint B = 0; B < n_bodies; ++B) {
    const float4 c4 = data[DFSPH_BODY_STRIDE * B];
    float3 wf = (float3)(0.0f), wt = (float3)(0.0f), vf = (float3)(0.0f), vt = (float3)(0.0f);
    if (c4.w != 0.0f) {
      DFSPH_COARSE_FOR_ROWS(&p, cell_start, cd, 0.0f, begin, end)
      for (uint k = begin; k < end; ++k) {
        if (mem[k] != (int)d) continue;
        const float3 xk = pos[k].xyz;
        __global const uint* bl = bnbr + (size_t)k * K;
        const uint nb = bnbr_count[k];
        float3 gf = (float3)(0.0f), gt = (float3)(0.0f);
        for (uint q = 0; q < nb; ++q) {
          const uint b = bl[q];
          if (sbody[b] != (int)B) continue;
          const float4 bb = bpos[b];
          const float3 dv = xk - bb.xyz;
          const float3 g = (bb.w * sph_grad_factor(SPH_KERNEL, length(dv), H)) * dv;
          gf += g;
          gt += cross(bb.xyz - c4.xyz, g);
        }
        const float dk = density[k] / p.phase_mass[phase[k]];
        const float v = wall / (dk * dk);
        wf += gf;
        wt += gt;
        vf += v * gf;
        vt += v * gt;
      }
      DFSPH_COARSE_END_ROWS
    }
    __global float4* o = cwv + ((size_t)d * n_bodies + B) * 4;
    o[0] = (float4)(scale * wf, 0.0f);
    o[1] = (float4)(scale * wt, 0.0f);
    o[2] = (float4)(vf, 0.0f);
    o[3] = (float4)(vt, 0.0f);
  }
}

/* y = K v for this work-item's rows (k = l, l + WG, ...), plus the free bodies' terms (n_bodies > 0,
 * the comment above dfsph_coarse_slot_body): y_k += scale W_k^B . M_B^-1 (V^B^T v). Called by every
 * work-item of the group (the bodies' sums are group sums). */
inline void dfsph_coarse_matvec(const uint l, const uint m, __global const float* kval, __global const int* kcol,
                                __global const float* v, __global float* y, const uint n_bodies,
                                __global const float4* cwv, __global const float4* data, __local float8* red8) {
  for (uint k = l; k < m; k += DFSPH_COARSE_WG) {
    /* eight slots at a time (slots 0..119, then 120..124), summed in slot order as fused multiply-adds;
     * a slot with no column (kcol -1) holds kval 0 (dfsph_coarse_assemble) and reads v[0] */
    __global const int* kc = kcol + (size_t)k * 125;
    __global const float* kv = kval + (size_t)k * 125;
    float s = 0.0f;
    for (int o = 0; o < 120; o += 8) {
      const int8 c = max(vload8(0, kc + o), (int8)(0));
      const float8 a = vload8(0, kv + o);
      const float8 x = (float8)(v[c.s0], v[c.s1], v[c.s2], v[c.s3], v[c.s4], v[c.s5], v[c.s6], v[c.s7]);
      s = fma(a.s0, x.s0, s);
      s = fma(a.s1, x.s1, s);
      s = fma(a.s2, x.s2, s);
      s = fma(a.s3, x.s3, s);
      s = fma(a.s4, x.s4, s);
      s = fma(a.s5, x.s5, s);
      s = fma(a.s6, x.s6, s);
      s = fma(a.s7, x.s7, s);
    }
    for (int o = 120; o < 125; ++o) s = fma(kv[o], v[max(kc[o], 0)], s);
    y[k] = s;
  }
  for (uint B = 0; B < n_bodies; ++B) {
    float8 part = (float8)(0.0f);
    for (uint k = l; k < m; k += DFSPH_COARSE_WG) {
      __global const float4* o = cwv + ((size_t)k * n_bodies + B) * 4;
      const float vk = v[k];
      part.s012 += vk * o[2].xyz;
      part.s345 += vk * o[3].xyz;
    }
    const float8 sv = dfsph_coarse_group_sum8(red8, part);
    /* M_B^-1 (F, T): the body's mobility (kernels/shared/body_response.h) */
    float3 af, aa;
    dfsph_body_mobility(data, B, sv.s012, sv.s345, &af, &aa);
    for (uint k = l; k < m; k += DFSPH_COARSE_WG) {
      __global const float4* o = cwv + ((size_t)k * n_bodies + B) * 4;
      y[k] += dot(o[0].xyz, af) + dot(o[1].xyz, aa);
    }
  }
}

/* K e = b by BiCGStab (van der Vorst 1992; Saad 2003, Alg. 7.7) with the Jacobi preconditioner on the
 * right, in one work-group (aggregate k is handled by work-item k mod DFSPH_COARSE_WG, the dot
 * products are group sums in a fixed order). K is not symmetric (the walls' w, the densities) and
 * its symmetric part need not be positive, so conjugate gradients can stall (the top of this file).
 * r0hat = b. Stops when |r| <= tol |b|, after max_it iterations, or at a
 * breakdown (a zero <r0hat, r>, <r0hat, v> or <t, t>, or omega = 0); e in x. mcount[1]: iterations. */
__kernel __attribute__((reqd_work_group_size(DFSPH_COARSE_WG, 1, 1)))
void dfsph_coarse_bicgstab(__global uint* mcount, __global const float* kval, __global const int* kcol,
                           __global const float* b, __global float* x, __global float* r, __global float* ph,
                           __global float* pv, __global float* v, __global float* sh, __global float* t,
                           const int max_it, const float tol, const uint n_bodies, __global const float4* cwv,
                           __global const float4* data) {
  __local float red[DFSPH_COARSE_WG];
  __local float8 red8[DFSPH_COARSE_WG];
  const uint l = get_local_id(0);
  const uint m = mcount[0];
  float bb_l = 0.0f;
  for (uint k = l; k < m; k += DFSPH_COARSE_WG) {
    x[k] = 0.0f;
    r[k] = b[k];
    pv[k] = 0.0f;
    v[k] = 0.0f;
    bb_l += b[k] * b[k];
  }
  const float bb = dfsph_coarse_group_sum(red, bb_l);
  barrier(CLK_GLOBAL_MEM_FENCE);
  float rho = 1.0f, alpha = 1.0f, omega = 1.0f, rr = bb;
  int it = 0;
  for (; it < max_it && rr > tol * tol * bb; ++it) {
    /* rho' = <r0hat, r>; p = r + beta (p - omega v); phat = D^-1 p */
    float l1 = 0.0f;
    for (uint k = l; k < m; k += DFSPH_COARSE_WG) l1 += b[k] * r[k];
    const float rho_new = dfsph_coarse_group_sum(red, l1);
    if (rho_new == 0.0f) break;
    const float beta = (rho_new / rho) * (alpha / omega);
    rho = rho_new;
    for (uint k = l; k < m; k += DFSPH_COARSE_WG) {
      const float pk = r[k] + beta * (pv[k] - omega * v[k]), dk = kval[(size_t)k * 125 + 62];
      pv[k] = pk;
      ph[k] = dk > 0.0f ? pk / dk : 0.0f;
    }
    barrier(CLK_GLOBAL_MEM_FENCE);
    /* v = K phat; alpha = rho / <r0hat, v>; s = r - alpha v (in r) */
    dfsph_coarse_matvec(l, m, kval, kcol, ph, v, n_bodies, cwv, data, red8);
    barrier(CLK_GLOBAL_MEM_FENCE);
    l1 = 0.0f;
    for (uint k = l; k < m; k += DFSPH_COARSE_WG) l1 += b[k] * v[k];
    const float r0v = dfsph_coarse_group_sum(red, l1);
    if (r0v == 0.0f) break;
    alpha = rho / r0v;
    l1 = 0.0f;
    for (uint k = l; k < m; k += DFSPH_COARSE_WG) {
      const float sk = r[k] - alpha * v[k], dk = kval[(size_t)k * 125 + 62];
      r[k] = sk;
      x[k] += alpha * ph[k];
      sh[k] = dk > 0.0f ? sk / dk : 0.0f;
      l1 += sk * sk;
    }
    rr = dfsph_coarse_group_sum(red, l1);
    barrier(CLK_GLOBAL_MEM_FENCE);
    if (!(rr > tol * tol * bb)) { ++it; break; }
    /* t = K shat; omega = <t, s> / <t, t>; x += omega shat; r = s - omega t */
    dfsph_coarse_matvec(l, m, kval, kcol, sh, t, n_bodies, cwv, data, red8);
    barrier(CLK_GLOBAL_MEM_FENCE);
    float l2 = 0.0f;
    l1 = 0.0f;
    for (uint k = l; k < m; k += DFSPH_COARSE_WG) l1 += t[k] * r[k], l2 += t[k] * t[k];
    const float ts = dfsph_coarse_group_sum(red, l1), tt = dfsph_coarse_group_sum(red, l2);
    if (!(tt > 0.0f)) break;
    omega = ts / tt;
    l1 = 0.0f;
    for (uint k = l; k < m; k += DFSPH_COARSE_WG) {
      x[k] += omega * sh[k];
      const float rk = r[k] - omega * t[k];
      r[k] = rk;
      l1 += rk * rk;
    }
    rr = dfsph_coarse_group_sum(red, l1);
    barrier(CLK_GLOBAL_MEM_FENCE);
    if (omega == 0.0f) { ++it; break; }
  }
  if (l == 0) mcount[1] = (uint)it;
}

/* Prolongation: dp_i = e of i's aggregate for the members, 0 for the others (unit: Pa). */
__kernel void dfsph_coarse_prolong(const SimParams p, __global const int* mem, __global const float* e,
                                   const float scale, __global float* dp) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const int k = mem[i];
  dp[i] = k >= 0 ? scale * e[k] : 0.0f;
}

/* The line search's trial pressures max(p_i + dp_i, 0) into `trial`, and their packed position and
 * p / delta^2 for dfsph_force. */
__kernel void dfsph_coarse_trial(const SimParams p, __global const float4* pos, __global const uint* phase,
                                 __global const float* density, __global const float* dp,
                                 __global const float* pressure, __global float* trial, __global float4* xt) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float p1 = fmax(pressure[i] + dp[i], 0.0f);
  trial[i] = p1;
  const float di = density[i] / p.phase_mass[phase[i]];
  xt[i] = (float4)(pos[i].xyz, p1 / (di * di));
}

/* The line search's sums per chunk of particles (in order): <q, r> and <q, dr> over the members,
 * dr = r(p + q) - r(p) (partial[2 c], partial[2 c + 1]). */
__kernel void dfsph_coarse_dots(const uint n, const uint chunk, const uint chunks, __global const int* mem,
                                __global const float* dp, __global const float* res, __global const float* trial_res,
                                __global float* partial) {
  const uint c = get_global_id(0);
  if (c >= chunks) return;
  const uint begin = c * chunk, end = min(begin + chunk, n);
  float qr = 0.0f, qdr = 0.0f;
  for (uint k = begin; k < end; ++k) {
    if (mem[k] < 0) continue;
    qr += dp[k] * res[k];
    qdr += dp[k] * (trial_res[k] - res[k]);
  }
  partial[2 * c] = qr;
  partial[2 * c + 1] = qdr;
}

/* theta = -<q, r> / <q, dr> within [0, theta_max] (0 when q does not lower the residual), the
 * chunks added in order (one work-item). */
__kernel void dfsph_coarse_theta(const uint chunks, __global const float* partial, const float theta_max,
                                 __global float* theta) {
  if (get_global_id(0) != 0) return;
  float qr = 0.0f, qdr = 0.0f;
  for (uint c = 0; c < chunks; ++c) qr += partial[2 * c], qdr += partial[2 * c + 1];
  theta[0] = qdr < 0.0f ? clamp(-qr / qdr, 0.0f, theta_max) : 0.0f;
}

/* The correction: p_i <- max(p_i + theta dp_i, 0), and the packed p / delta^2 the next
 * pressure-force pass gathers. */
__kernel void dfsph_coarse_apply(const SimParams p, __global const float4* pos, __global const uint* phase,
                                 __global const float* density, __global const float* dp,
                                 __global const float* theta, __global float* pressure, __global float4* xt) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float p1 = fmax(pressure[i] + theta[0] * dp[i], 0.0f);
  pressure[i] = p1;
  const float di = density[i] / p.phase_mass[phase[i]];
  xt[i] = (float4)(pos[i].xyz, p1 / (di * di));
}
