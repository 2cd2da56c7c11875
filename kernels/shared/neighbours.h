/* Neighbour iteration over the cell grid (device side only).
 *
 * Particles are sorted by cell, x fastest, so for each (y, z) row of the 3x3x3 block around a
 * particle the three cells x-1..x+1 are one contiguous range [cell_start[a], cell_start[b+1]).
 * cell_start has num_cells + 1 entries (an exclusive prefix sum of the per-cell counts).
 *
 *     z+1 row  [ . . . ]      each row: one contiguous run of sorted particles
 *     z   row  [ . i . ]      9 runs in all, instead of 27 cell look-ups
 *     z-1 row  [ . . . ]
 *
 * Usage:   SPH_FOR_NEIGHBOURS(p, cell_start, xi, j) { ... uses j ... } SPH_END_NEIGHBOURS
 */
#ifndef SPHAPTICS_NEIGHBOURS_H
#define SPHAPTICS_NEIGHBOURS_H
#ifdef __OPENCL_VERSION__

inline int3 sph_cell_of(const SimParams* p, float3 x) {
  const float3 o = (float3)(p->grid_origin[0], p->grid_origin[1], p->grid_origin[2]);
  int3 c = convert_int3_rtn((x - o) / p->cell_size);
  c = clamp(c, (int3)(0, 0, 0), (int3)(p->grid_dims[0] - 1, p->grid_dims[1] - 1, p->grid_dims[2] - 1));
  return c;
}

inline uint sph_cell_index(const SimParams* p, int3 c) {
  return (uint)(c.x + p->grid_dims[0] * (c.y + p->grid_dims[1] * c.z));
}

#define SPH_END_NEIGHBOURS \
  }                        \
  }

/* The 9 rows as ranges [BEGIN, END) of sorted particles, for loops that take a range at once. */
#define SPH_FOR_NEIGHBOUR_ROWS(P, CELL_START, XI, BEGIN, END)                             \
  {                                                                                       \
    const int3 c_ = sph_cell_of(P, XI);                                                   \
    const int xa_ = max(c_.x - 1, 0), xb_ = min(c_.x + 1, (P)->grid_dims[0] - 1);         \
    for (int z_ = max(c_.z - 1, 0); z_ <= min(c_.z + 1, (P)->grid_dims[2] - 1); ++z_)     \
      for (int y_ = max(c_.y - 1, 0); y_ <= min(c_.y + 1, (P)->grid_dims[1] - 1); ++y_) { \
        const uint row_ = (uint)((P)->grid_dims[0] * (y_ + (P)->grid_dims[1] * z_));      \
        const uint BEGIN = CELL_START[row_ + (uint)xa_];                                  \
        const uint END = CELL_START[row_ + (uint)xb_ + 1u];


/* One particle J at a time over the same rows. */
#define SPH_FOR_NEIGHBOURS(P, CELL_START, XI, J) \
  SPH_FOR_NEIGHBOUR_ROWS(P, CELL_START, XI, row_begin_, row_end_) for (uint J = row_begin_; J < row_end_; ++J)

#endif
#endif
