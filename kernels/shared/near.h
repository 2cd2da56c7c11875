/* Gathering every particle near a point through the neighbour grid's cell table, for stages that
 * sample the particles at points that are not particles (the isosurface's grid nodes, probes).
 * Particles move after they are sorted into cells (Verlet lists), so callers pass
 * reach = H + the largest drift since the grid was built. OpenCL C only. */
#ifndef SPHAPTICS_NEAR_H
#define SPHAPTICS_NEAR_H
#ifdef __OPENCL_VERSION__

/* Neighbour-grid cells that can hold a particle within `reach` of x. */
inline void sph_cell_range(const SimParams* p, float3 x, float reach, int3* lo, int3* hi) {
  const float3 o = (float3)(p->grid_origin[0], p->grid_origin[1], p->grid_origin[2]);
  const int3 top = (int3)(p->grid_dims[0] - 1, p->grid_dims[1] - 1, p->grid_dims[2] - 1);
  *lo = clamp(convert_int3_rtn((x - reach - o) / p->cell_size), (int3)(0), top);
  *hi = clamp(convert_int3_rtn((x + reach - o) / p->cell_size), (int3)(0), top);
}

/* Every particle S in the cells within REACH of X, in grid order (one contiguous run per row of
 * cells, as in neighbours.h); CELL_START is the fluid's or the boundary's cell table.
 *   FOR_PARTICLES_NEAR(p, cell_start, x, reach, s) { ... uses s ... } END_PARTICLES_NEAR */
#define FOR_PARTICLES_NEAR(P, CELL_START, X, REACH, S)                                   \
  {                                                                                      \
    int3 lo_, hi_;                                                                       \
    sph_cell_range(P, X, REACH, &lo_, &hi_);                                             \
    for (int cz_ = lo_.z; cz_ <= hi_.z; ++cz_)                                           \
      for (int cy_ = lo_.y; cy_ <= hi_.y; ++cy_) {                                       \
        const uint row_ = (uint)((P)->grid_dims[0] * (cy_ + (P)->grid_dims[1] * cz_));   \
        const uint end_ = CELL_START[row_ + (uint)hi_.x + 1u];                           \
        for (uint S = CELL_START[row_ + (uint)lo_.x]; S < end_; ++S)

#define END_PARTICLES_NEAR \
  }                        \
  }

#endif
#endif
