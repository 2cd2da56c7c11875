/* Smoothing kernels, shared by the host (C++) and the device (OpenCL C).
 *
 * Both kernels are written in terms of the support radius H (the neighbour-grid cell size) and
 * q = r / H in [0, 1]; both are normalised in 3D (integral of W over space = 1).
 *   cubic spline (Monaghan 1992; the SPHaptics paper's kernel), h = H/2:
 *       W = s (6 q^3 - 6 q^2 + 1)   for q <= 1/2,   W = 2 s (1 - q)^3   for q <= 1,   s = 8 / (pi H^3)
 *   Wendland C2 (Wendland 1995; Dehnen & Aly 2012):
 *       W = s (1 - q)^4 (1 + 4 q),  s = 21 / (2 pi H^3)
 * sph_grad_factor() returns F with grad W(r_vec) = F * r_vec, finite at r = 0. */
#ifndef SPHAPTICS_SPH_KERNEL_H
#define SPHAPTICS_SPH_KERNEL_H

#ifdef __OPENCL_VERSION__
#define SPH_FN inline
#define SPH_SQRT sqrt
#else
#include <cmath>
#define SPH_FN inline
#define SPH_SQRT std::sqrt
#endif

#define SPH_PI_F 3.14159265358979f
#define SPH_KERNEL_CUBIC_SPLINE 0
#define SPH_KERNEL_WENDLAND_C2 1

/* The kernels below are written without branches on q (both pieces are computed and one is
 * selected, and t = max(1 - q, 0) zeroes everything beyond the support) so that the neighbour
 * loops, where q is effectively random, compile to selects rather than mispredicted jumps. */
SPH_FN float sph_cubic_w(float r, float H) {
  const float inv_h = 1.0f / H; /* loop-invariant in the neighbour loops: one multiply per pair */
  const float q = r * inv_h;
  const float s = 8.0f / SPH_PI_F * inv_h * inv_h * inv_h;
  const float t = 1.0f - q > 0.0f ? 1.0f - q : 0.0f;
  const float inner = 6.0f * q * q * q - 6.0f * q * q + 1.0f;
  const float outer = 2.0f * t * t * t;
  return s * (q <= 0.5f ? inner : outer);
}

/* dW/dr / r, so that grad W = factor * r_vec. */
SPH_FN float sph_cubic_grad_factor(float r, float H) {
  const float inv_h = 1.0f / H;
  const float q = r * inv_h;
  const float s = 8.0f / SPH_PI_F * inv_h * inv_h * inv_h;
  const float t = 1.0f - q > 0.0f ? 1.0f - q : 0.0f;
  const float qs = q > 0.25f ? q : 0.25f; /* the outer piece is used only for q > 1/2 */
  const float inner = 18.0f * q - 12.0f;  /* (18 q^2 - 12 q) / q */
  const float outer = -6.0f * t * t / qs; /* -6 (1 - q)^2 / q */
  return s * (q <= 0.5f ? inner : outer) * (inv_h * inv_h);
}

SPH_FN float sph_wendland_w(float r, float H) {
  const float inv_h = 1.0f / H;
  const float q = r * inv_h;
  const float s = 21.0f / (2.0f * SPH_PI_F) * inv_h * inv_h * inv_h;
  const float t = 1.0f - q > 0.0f ? 1.0f - q : 0.0f;
  return s * t * t * t * t * (1.0f + 4.0f * q);
}

SPH_FN float sph_wendland_grad_factor(float r, float H) {
  const float inv_h = 1.0f / H;
  const float q = r * inv_h;
  const float s = 21.0f / (2.0f * SPH_PI_F) * inv_h * inv_h * inv_h;
  const float t = 1.0f - q > 0.0f ? 1.0f - q : 0.0f;
  return -20.0f * s * t * t * t * (inv_h * inv_h); /* dW/dq = -20 s q t^3; divided by (H r) with q/r = 1/H */
}

SPH_FN float sph_w(int kind, float r, float H) {
  return kind == SPH_KERNEL_WENDLAND_C2 ? sph_wendland_w(r, H) : sph_cubic_w(r, H);
}

SPH_FN float sph_grad_factor(int kind, float r, float H) {
  return kind == SPH_KERNEL_WENDLAND_C2 ? sph_wendland_grad_factor(r, H) : sph_cubic_grad_factor(r, H);
}

#endif
