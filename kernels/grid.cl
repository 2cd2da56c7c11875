/* Neighbour grid (stage: grid). Counting sort of the fluid particles by cell, as in the
 * SPHaptics paper: cell per particle -> count per cell -> prefix sum (scan.cl) -> sorted index,
 * then every field is gathered into cell order for memory locality.
 * Deterministic: integer atomics only count; the order inside each cell is then fixed by sorting
 * the (short) run of each cell by previous index, so the result never depends on thread timing.
 *
 * Verlet lists (Verlet 1967): the cells are H + skin wide and each particle records every fluid
 * and boundary particle within H + skin. The lists stay valid until some particle has moved
 * skin / 2 (the host tracks the largest speed per step), so the sort, the reorder and the 27-cell
 * scan run every few steps instead of every step. */

/* 1. Cell of each particle and its arrival rank within the cell. cell_count must be zeroed. */
__kernel void grid_assign(const SimParams p, __global const float4* pos, __global uint* cell,
                          __global uint* rank, volatile __global uint* cell_count) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const uint c = sph_cell_index(&p, sph_cell_of(&p, pos[i].xyz));
  cell[i] = c;
  rank[i] = atomic_inc(&cell_count[c]);
}

/* 2. Place each particle at cell_start[cell] + rank. */
__kernel void grid_scatter(const SimParams p, __global const uint* cell, __global const uint* rank,
                           __global const uint* cell_start, __global uint* sorted) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  sorted[cell_start[cell[i]] + rank[i]] = i;
}

/* 3. Make the order inside each cell deterministic: the first slot of each cell sorts its run. */
__kernel void grid_order_cells(const SimParams p, __global const uint* cell, __global const uint* cell_start,
                               __global uint* sorted) {
  const uint s = get_global_id(0);
  if (s >= p.n_fluid) return;
  const uint c = cell[sorted[s]];
  const uint begin = cell_start[c];
  if (s != begin) return;
  const uint end = cell_start[c + 1];
  for (uint a = begin + 1; a < end; ++a) { /* insertion sort: runs hold ~8 particles */
    const uint v = sorted[a];
    uint b = a;
    while (b > begin && sorted[b - 1] > v) { sorted[b] = sorted[b - 1]; --b; }
    sorted[b] = v;
  }
}

/* 4. Gather every per-particle field into sorted order (double buffers; the host swaps). */
__kernel void grid_reorder(const SimParams p, __global const uint* sorted,
                           __global const float4* pos, __global const float4* vel, __global const float4* colour,
                           __global const uint* phase, __global const uint* id,
                           __global float4* pos_out, __global float4* vel_out, __global float4* colour_out,
                           __global uint* phase_out, __global uint* id_out) {
  const uint s = get_global_id(0);
  if (s >= p.n_fluid) return;
  const uint j = sorted[s];
  pos_out[s] = pos[j];
  vel_out[s] = vel[j];
  colour_out[s] = colour[j];
  phase_out[s] = phase[j];
  id_out[s] = id[j];
}

/* 5. Neighbour lists: every fluid and boundary particle within the list radius `radius` (at most
 * the cell size: H + skin for Verlet lists, H for DFSPH's lists of one step, core/simulation.cpp
 * buildGrid), self excluded, in grid order (deterministic). A list that overflows keeps its first
 * max_neighbours entries and the largest count goes to the host, which grows the lists.
 * Fluid lists are narrow (16-bit offsets j - i) unless p.wide_lists (shared/neighbours.h): a
 * particle whose candidates' offsets do not all fit in 16 bits (its 9 rows span more than
 * -32768..32767 around i) sets *narrow_fail, and the host builds the lists again, wide. */
__kernel void build_neighbour_lists(const SimParams p, __global const float4* pos, __global const uint* cell_start,
                                    __global const float4* bpos, __global const uint* bcell_start,
                                    __global uint* nbr, __global uint* nbr_count, __global uint* bnbr,
                                    __global uint* bnbr_count, volatile __global uint* overflow,
                                    const float radius, volatile __global uint* narrow_fail) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 xi = pos[i].xyz;
  const float R2 = radius * radius; /* (unit: m^2) */
  const uint K = p.max_neighbours;
  __global uint* my_nbr = nbr + (size_t)i * K;
  __global short* my_snbr = p.wide_lists ? 0 : (__global short*)nbr + (size_t)i * K;
  __global uint* my_bnbr = bnbr + (size_t)i * K;
  /* Row by row, eight candidates at a time (shared/pair_loops.h). */
  uint count = 0;
  uint lo = i, hi = i + 1; /* the candidates' range */
  SPH_FOR_NEIGHBOUR_ROWS(&p, cell_start, xi, begin, end) {
    lo = min(lo, begin);
    hi = max(hi, end);
    count = sph_collect_row(xi, pos, begin, end, R2, i, my_nbr, my_snbr, (int)i, K, count);
  }
  SPH_END_NEIGHBOURS
  if (my_snbr && (i - lo > 32768u || hi - 1u - i > 32767u)) atomic_or(narrow_fail, 1u);
  uint bcount = 0;
  SPH_FOR_NEIGHBOUR_ROWS(&p, bcell_start, xi, begin, end) {
    bcount = sph_collect_row(xi, bpos, begin, end, R2, 0xffffffffu, my_bnbr, 0, 0, K, bcount);
  }
  SPH_END_NEIGHBOURS
  nbr_count[i] = min(count, K);
  bnbr_count[i] = min(bcount, K);
  if (count > K || bcount > K) atomic_max(overflow, max(count, bcount));
}
