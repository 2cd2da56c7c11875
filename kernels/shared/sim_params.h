/* SimParams: every constant the kernels need, in one struct passed by value to each kernel.
 * Compiled both as C++ (host) and OpenCL C (device): only 4-byte scalars and arrays of them, so
 * the layout is identical on both sides (checked with static_assert on the host). */
#ifndef SPHAPTICS_SIM_PARAMS_H
#define SPHAPTICS_SIM_PARAMS_H

#ifndef __OPENCL_VERSION__
#include <cstdint>
typedef uint32_t sph_uint;
#else
typedef uint sph_uint;
#endif

#define SPH_MAX_PHASES 8
#define SPH_EOS_LINEAR 0
#define SPH_EOS_TAIT 1

typedef struct SimParams {
  /* neighbour grid: cell (cx, cy, cz) covers grid_origin + [c, c+1) * cell_size */
  float grid_origin[4];   /* (unit: m) */
  int grid_dims[4];       /* cells per axis */
  float cell_size;        /* = neighbour-list radius, support H + skin (unit: m) */
  float support;          /* kernel support radius H (unit: m) */
  float h;                /* smoothing length H/2, used by CFL and viscosity (unit: m) */
  float rest_volume;      /* particle volume dx^3 (unit: m^3) */
  /* domain box and closed-wall mask (bit w set = wall w closed, w in x_min..z_max) */
  float domain_min[4];    /* (unit: m) */
  float domain_max[4];    /* (unit: m) */
  sph_uint closed_mask;
  sph_uint kernel_type;   /* SPH_KERNEL_* (the device uses the SPH_KERNEL build option) */
  sph_uint eos;           /* SPH_EOS_* */
  sph_uint clamp_negative_pressure;
  float background_pressure; /* added to the equation of state (WCSPH; fluid.background_pressure) (unit: Pa) */
  sph_uint n_fluid;       /* active fluid particles */
  sph_uint n_boundary;    /* static boundary particles */
  sph_uint num_cells;     /* grid_dims product */
  sph_uint max_neighbours; /* neighbour-list slots per particle (fluid and boundary lists alike) */
  sph_uint wide_lists;    /* 1: fluid lists hold 32-bit indices; 0: 16-bit offsets j - i (shared/neighbours.h) */
  /* time integration */
  float dt;               /* (unit: s) */
  float gravity[4];       /* current gravity, ramp applied (unit: m/s^2) */
  /* fluid */
  float c0;               /* speed of sound (unit: m/s) */
  float alpha;            /* Monaghan artificial viscosity coefficient (unit: 1) */
  float colour_diffusion; /* (unit: m^2/s) */
  sph_uint body_viscosity; /* 1: fluid-body viscous term with the phase viscosity, laminar form (BodyViscosity::Physical) */
  float phase_rest_density[SPH_MAX_PHASES]; /* (unit: kg/m^3) */
  float phase_mass[SPH_MAX_PHASES];         /* rest_density * dx^3 (unit: kg) */
  float phase_viscosity[SPH_MAX_PHASES];    /* kinematic (unit: m^2/s) */
} SimParams;

#endif
