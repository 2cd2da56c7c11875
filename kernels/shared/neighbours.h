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

/* Fluid neighbour lists, narrow or wide (performance, issue 14). Every pass of a step streams the
 * lists (~40 slots per particle, ~12-16 passes per DFSPH step; at 50k the 32-bit lists are ~8 MB,
 * larger than the L2 cache). Particles are sorted by cell, so a fluid neighbour's index j is close
 * to the particle's own i: a narrow list (p->wide_lists = 0) stores j - i as a 16-bit signed
 * offset, half the bytes. Its slots are shorts, max_neighbours per particle, packed in the first
 * half of the list buffer (which keeps 4 bytes per slot for the wide form). The list build checks
 * that every candidate's offset fits (build_neighbour_lists, `narrow_fail`); where one does not (a
 * scene with more than 32,767 particles within one cell layer of the grid), the host switches to
 * wide lists, 32-bit indices, and builds them again (core/simulation.cpp buildGrid). Either way a
 * list holds the same neighbours in the same order: results are bitwise the same.
 * Boundary lists index the boundary particles and stay 32-bit. */
typedef struct {
  __global const uint* w;  /* wide: the particle's 32-bit indices, else 0 */
  __global const short* s; /* narrow: the particle's offsets j - i */
  int i;
} SphList;

/* Particle i's list in `lists` (K slots per particle), wide or narrow as `wide` says (boundary
 * lists: always wide). */
inline SphList sph_list_k(__global const uint* lists, const uint i, const uint K, const int wide) {
  SphList l;
  l.i = (int)i;
  l.w = wide ? lists + (size_t)i * K : 0;
  l.s = (__global const short*)lists + (size_t)i * K;
  return l;
}

/* Particle i's fluid list in `nbr` (the fluid list buffer, either form). */
inline SphList sph_list(const SimParams* p, __global const uint* nbr, const uint i) {
  return sph_list_k(nbr, i, p->max_neighbours, p->wide_lists ? 1 : 0);
}

/* Entries k..k+7, and entry k, as indices. */
inline uint8 sph_list8(const SphList l, const uint k) {
  return l.w ? vload8(0, l.w + k) : as_uint8(convert_int8(vload8(0, l.s + k)) + (int8)(l.i));
}
/* Around device code that passes 16-wide vectors (float16, uint16) to functions, built-ins included: clang
 * warns on a CPU without AVX-512 that their calling convention differs ("AVX vector argument ... changes
 * the ABI"), and pocl printed such warnings to the user's stderr (session 46). Harmless here: the program
 * is one translation unit and these functions are inlined. */
#ifdef __clang__
#define SPH_PSABI_QUIET _Pragma("clang diagnostic push") _Pragma("clang diagnostic ignored \"-Wpsabi\"")
#define SPH_PSABI_LOUD _Pragma("clang diagnostic pop")
#else
#define SPH_PSABI_QUIET
#define SPH_PSABI_LOUD
#endif

/* Entries k..k+15 (the solves' sixteen-wide loops, shared/pair_loops.h). A 16-wide vector return: clang's
 * calling-convention warning on CPUs without AVX-512 is silenced (SPH_PSABI_QUIET, below). */
SPH_PSABI_QUIET
inline uint16 sph_list16(const SphList l, const uint k) {
  return l.w ? vload16(0, l.w + k) : as_uint16(convert_int16(vload16(0, l.s + k)) + (int16)(l.i));
}
SPH_PSABI_LOUD
inline uint sph_list1(const SphList l, const uint k) { return l.w ? l.w[k] : (uint)(l.i + (int)l.s[k]); }

/* The narrow offset of candidate j from particle i (valid where it fits: the build checks). */
#define SPH_NARROW_OFFSET8(J, I) convert_short8(as_int8(J) - (int8)((int)(I)))

#endif
#endif
