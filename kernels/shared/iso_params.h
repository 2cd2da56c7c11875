/* IsoParams: the surface grid of the isosurface stage (kernels/isosurface.cl), shared by host and
 * device like SimParams. Node (i, j, k) sits at origin + spacing * (i, j, k); nodes are numbered
 * x fastest, then y, then z; cell (i, j, k) spans nodes (i..i+1, j..j+1, k..k+1). */
#ifndef SPHAPTICS_ISO_PARAMS_H
#define SPHAPTICS_ISO_PARAMS_H

/* Room per marching-cubes case in the triangle table (core/marching_cubes_table.h). */
#define MC_MAX_TRIANGLES 10

typedef struct IsoParams {
  float origin[4];        /* world position of node (0, 0, 0) (unit: m) */
  int dims[4];            /* nodes per axis */
  float spacing;          /* distance between neighbouring nodes (unit: m) */
  float iso;              /* surface value of the normalised field (unit: 1) */
  sph_uint num_nodes;     /* dims[0] * dims[1] * dims[2] */
  sph_uint num_fields;    /* fields stored one after the other (one per phase) */
  sph_uint field;         /* the field being meshed */
  sph_uint with_colour;   /* 1: vertex colours from the particles of phase `field` */
  float reach;            /* gather radius: H + the largest drift since the neighbour grid was built (unit: m) */
  sph_uint pad;
} IsoParams;

#endif
