/* Isosurface (per output frame, only when output.isosurface is enabled): a normalised surface
 * field per fluid phase on a regular grid, then marching cubes (Lorensen & Cline 1987) with welded
 * vertices. Everything is a gather with a fixed order, so the mesh is the same bit for bit on a
 * given device.
 *
 * Field (per phase f):   F_f(x) = sum over particles j of phase f of V0 W(|x - x_j|, H)
 * with V0 = dx^3 the rest volume and W the simulation's kernel: inside the fluid at rest F ~ 1,
 * far outside F = 0, and across a flat free surface F falls through 1/2 where the continuum
 * (each particle owning a dx^3 cube) ends, half a spacing outside the outer particle layer. The
 * default iso value is therefore 0.5.
 *
 * Marching cubes, as a sequence of data-parallel passes:
 *   mc_node_edges     node -> which of its 3 edges (+x, +y, +z) cross the surface (mask, count)
 *   mc_cell_count     cell -> triangle count from its case (table built on the host)
 *   (prefix sums of both counts: scan.cl)
 *   mc_emit_vertices  node -> one vertex per crossing edge it owns (the edge's lower node), so
 *                     neighbouring cells share vertices: the mesh is welded and watertight
 *   mc_emit_triangles cell -> its triangles, in cell order, as indices of the shared vertices
 */

/* Particles near a node: FOR_PARTICLES_NEAR (kernels/shared/near.h). */

/* Node n -> (i, j, k). */
inline int3 iso_node_ijk(const IsoParams* q, uint n) {
  return (int3)((int)(n % (uint)q->dims[0]), (int)((n / (uint)q->dims[0]) % (uint)q->dims[1]),
                (int)(n / ((uint)q->dims[0] * (uint)q->dims[1])));
}

inline float3 iso_node_pos(const IsoParams* q, int i, int j, int k) {
  return (float3)(q->origin[0], q->origin[1], q->origin[2]) + q->spacing * (float3)((float)i, (float)j, (float)k);
}

/* Bounding box of the fluid: each work-item reduces one chunk of particles to (min xyz, max xyz). */
__kernel void iso_bounds(const SimParams p, const uint chunk, __global const float4* pos, __global float* out) {
  const uint g = get_global_id(0);
  float3 lo = (float3)(INFINITY), hi = (float3)(-INFINITY);
  const uint end = min((g + 1) * chunk, p.n_fluid);
  for (uint i = g * chunk; i < end; ++i) {
    const float3 x = pos[i].xyz;
    if (all(isfinite(x))) { lo = fmin(lo, x); hi = fmax(hi, x); }
  }
  out[6 * g + 0] = lo.x; out[6 * g + 1] = lo.y; out[6 * g + 2] = lo.z;
  out[6 * g + 3] = hi.x; out[6 * g + 4] = hi.y; out[6 * g + 5] = hi.z;
}

/* F_f at every node, for every phase f < num_fields: field[f * num_nodes + node]. */
__kernel void iso_field(const SimParams p, const IsoParams q, __global const float4* pos, __global const uint* phase,
                        __global const uint* cell_start, __global float* field) {
  const uint n = get_global_id(0);
  if (n >= q.num_nodes) return;
  const int3 c = iso_node_ijk(&q, n);
  const float3 x = iso_node_pos(&q, c.x, c.y, c.z);
  const float H = p.support, H2 = H * H;
  float acc[SPH_MAX_PHASES];
  for (uint f = 0; f < SPH_MAX_PHASES; ++f) acc[f] = 0.0f;
  FOR_PARTICLES_NEAR(&p, cell_start, x, q.reach, s) {
    const float3 d = x - pos[s].xyz;
    const float r2 = dot(d, d);
    if (r2 < H2) acc[min(phase[s], (uint)(SPH_MAX_PHASES - 1))] += sph_w(SPH_KERNEL, sqrt(r2), H);
  }
  END_PARTICLES_NEAR
  for (uint f = 0; f < q.num_fields; ++f) field[(size_t)f * q.num_nodes + n] = p.rest_volume * acc[f];
}

/* Which of the node's edges towards +x, +y, +z cross the surface (bit a), and how many. */
__kernel void mc_node_edges(const IsoParams q, __global const float* field, __global uint* edge_mask,
                            __global uint* vert_count) {
  const uint n = get_global_id(0);
  if (n >= q.num_nodes) return;
  __global const float* F = field + (size_t)q.field * q.num_nodes;
  const int3 c = iso_node_ijk(&q, n);
  const int in0 = F[n] > q.iso;
  const uint step[3] = {1u, (uint)q.dims[0], (uint)(q.dims[0] * q.dims[1])};
  const int room[3] = {c.x + 1 < q.dims[0], c.y + 1 < q.dims[1], c.z + 1 < q.dims[2]};
  uint mask = 0;
  for (int a = 0; a < 3; ++a)
    if (room[a] && ((F[n + step[a]] > q.iso) != in0)) mask |= 1u << a;
  edge_mask[n] = mask;
  vert_count[n] = popcount(mask);
}

/* Case of cell c: bit (x + 2y + 4z) set when that corner is inside (F > iso). */
inline uint mc_case(const IsoParams* q, __global const float* F, int i, int j, int k) {
  const uint base = (uint)(i + q->dims[0] * (j + q->dims[1] * k));
  const uint sy = (uint)q->dims[0], sz = (uint)(q->dims[0] * q->dims[1]);
  uint cs = 0;
  for (uint c = 0; c < 8; ++c) {
    const uint node = base + (c & 1u) + ((c >> 1) & 1u) * sy + ((c >> 2) & 1u) * sz;
    if (F[node] > q->iso) cs |= 1u << c;
  }
  return cs;
}

__kernel void mc_cell_count(const IsoParams q, __global const float* field, __global const uchar* case_triangles,
                            __global uint* tri_count) {
  const uint c = get_global_id(0);
  const uint cx = (uint)q.dims[0] - 1u, cy = (uint)q.dims[1] - 1u, cz = (uint)q.dims[2] - 1u;
  if (c >= cx * cy * cz) return;
  const int i = (int)(c % cx), j = (int)((c / cx) % cy), k = (int)(c / (cx * cy));
  tri_count[c] = case_triangles[mc_case(&q, field + (size_t)q.field * q.num_nodes, i, j, k)];
}

/* Field gradient at a node by central differences (one-sided at the grid border). */
inline float3 mc_gradient(const IsoParams* q, __global const float* F, int i, int j, int k) {
  const int idx[3] = {i, j, k};
  const uint step[3] = {1u, (uint)q->dims[0], (uint)(q->dims[0] * q->dims[1])};
  const uint n = (uint)(i + q->dims[0] * (j + q->dims[1] * k));
  float g[3];
  for (int a = 0; a < 3; ++a) {
    const uint up = idx[a] + 1 < q->dims[a] ? n + step[a] : n;
    const uint dn = idx[a] > 0 ? n - step[a] : n;
    const float h = (float)((up != n) + (dn != n)) * q->spacing;
    g[a] = h > 0.0f ? (F[up] - F[dn]) / h : 0.0f;
  }
  return (float3)(g[0], g[1], g[2]);
}

/* One vertex per crossing edge, at vert_offset[node] + (rank of the edge among the node's crossing
 * edges): linear interpolation along the edge, normal from the interpolated field gradient
 * (pointing outward, where the field decreases), and optionally the Shepard-averaged colour of the
 * phase's particles within H. */
__kernel void mc_emit_vertices(const SimParams p, const IsoParams q, __global const float* field,
                               __global const uint* edge_mask, __global const uint* vert_offset,
                               __global const float4* pos, __global const uint* phase, __global const float4* colour,
                               __global const uint* cell_start, __global float4* vert_pos, __global float4* vert_normal,
                               __global float4* vert_colour) {
  const uint n = get_global_id(0);
  if (n >= q.num_nodes) return;
  const uint mask = edge_mask[n];
  if (mask == 0u) return;
  __global const float* F = field + (size_t)q.field * q.num_nodes;
  const int3 c = iso_node_ijk(&q, n);
  const int i = c.x, j = c.y, k = c.z;
  const uint step[3] = {1u, (uint)q.dims[0], (uint)(q.dims[0] * q.dims[1])};
  uint out = vert_offset[n];
  const float3 g0 = mc_gradient(&q, F, i, j, k);
  for (int a = 0; a < 3; ++a) {
    if (!((mask >> a) & 1u)) continue;
    const float f0 = F[n], f1 = F[n + step[a]];
    const float t = clamp((q.iso - f0) / (f1 - f0), 0.0f, 1.0f);
    const int3 e = (int3)(a == 0, a == 1, a == 2);
    const float3 x = iso_node_pos(&q, i, j, k) + (t * q.spacing) * convert_float3(e);
    const float3 g = mix(g0, mc_gradient(&q, F, i + e.x, j + e.y, k + e.z), t);
    const float len = length(g);
    vert_pos[out] = (float4)(x, 0.0f);
    vert_normal[out] = len > 0.0f ? (float4)(-g / len, 0.0f) : (float4)(0.0f, 0.0f, 1.0f, 0.0f);
    if (q.with_colour) {
      const float H = p.support, H2 = H * H;
      float4 c = (float4)(0.0f);
      float wsum = 0.0f;
      int3 lo, hi;
      sph_cell_range(&p, x, q.reach, &lo, &hi);
      for (int cz = lo.z; cz <= hi.z; ++cz)
        for (int cy = lo.y; cy <= hi.y; ++cy) {
          const uint row = (uint)(p.grid_dims[0] * (cy + p.grid_dims[1] * cz));
          const uint end = cell_start[row + (uint)hi.x + 1u];
          for (uint s = cell_start[row + (uint)lo.x]; s < end; ++s) {
            const float3 d = x - pos[s].xyz;
            const float r2 = dot(d, d);
            if (r2 < H2 && phase[s] == q.field) {
              const float w = sph_w(SPH_KERNEL, sqrt(r2), H);
              c += w * colour[s];
              wsum += w;
            }
          }
        }
      vert_colour[out] = wsum > 0.0f ? c / wsum : (float4)(0.0f);
    }
    ++out;
  }
}

/* The triangles of each cell at tri_offset[cell], as indices into the welded vertices. Edge e of
 * the table runs along axis a = e / 4 from the cell corner whose other two coordinates are
 * (e & 1, (e >> 1) & 1) in axis order. */
__kernel void mc_emit_triangles(const IsoParams q, __global const float* field, __global const uchar* case_triangles,
                                __global const uchar* case_edges, __global const uint* edge_mask,
                                __global const uint* vert_offset, __global const uint* tri_offset,
                                __global uint* tris) {
  const uint c = get_global_id(0);
  const uint cx = (uint)q.dims[0] - 1u, cy = (uint)q.dims[1] - 1u, cz = (uint)q.dims[2] - 1u;
  if (c >= cx * cy * cz) return;
  const int i = (int)(c % cx), j = (int)((c / cx) % cy), k = (int)(c / (cx * cy));
  const uint cs = mc_case(&q, field + (size_t)q.field * q.num_nodes, i, j, k);
  const uint count = case_triangles[cs];
  if (count == 0u) return;
  const uint sy = (uint)q.dims[0], sz = (uint)(q.dims[0] * q.dims[1]);
  const uint base = (uint)(i + q.dims[0] * (j + q.dims[1] * k));
  uint out = 3u * tri_offset[c];
  for (uint v = 0; v < 3u * count; ++v) {
    const uint e = case_edges[cs * (3u * MC_MAX_TRIANGLES) + v];
    const uint a = e / 4u, u = e & 1u, w = (e >> 1) & 1u;
    /* corner offset (ox, oy, oz): u and w fill the two axes other than a, in order */
    const uint o1 = a == 0u ? 1u : 0u, o2 = a == 2u ? 1u : 2u;
    uint off[3] = {0u, 0u, 0u};
    off[o1] = u;
    off[o2] = w;
    const uint node = base + off[0] + off[1] * sy + off[2] * sz;
    tris[out++] = vert_offset[node] + popcount(edge_mask[node] & ((1u << a) - 1u));
  }
}
