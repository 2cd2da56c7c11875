/* The viscous acceleration of particle i due to neighbour j (device side only), shared by the
 * viscosity stage (viscosity.cl) and the fused pressure + viscosity pass (pressure.cl).
 *
 * artificial (Monaghan 1992, eq. 4.2 of Monaghan 2005):
 *     a_i += -sum_j m_j Pi_ij grad W_ij,  Pi_ij = -alpha c0 h mu_ij / rho_ij  (approaching pairs only),
 *     mu_ij = (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2),  rho_ij = (rho_i + rho_j) / 2
 * laminar (Morris, Fox & Zhu 1997, eq. 8; built with -DSPH_LAMINAR=1):
 *     a_i += sum_j m_j (mu_i + mu_j) / (rho_i rho_j) (x_ij . grad W_ij) / (|x_ij|^2 + 0.01 h^2) v_ij,
 *     mu = rho nu (dynamic viscosity from the phase's kinematic viscosity nu)
 * d = x_i - x_j, r2 = |d|^2, F = grad-W factor (grad W_ij = F d), vij = v_i - v_j. */
#ifndef SPHAPTICS_VISCOSITY_TERM_H
#define SPHAPTICS_VISCOSITY_TERM_H
#ifdef __OPENCL_VERSION__

inline float3 sph_viscosity_pair(const SimParams* p, const float3 d, const float r2, const float F, const float3 vij,
                                 const float rhoi, const float mui, const float rhoj, const uint phj) {
  const float eta2 = 0.01f * p->h * p->h;
  const float mj = p->phase_mass[phj];
#if SPH_LAMINAR
  const float muj = rhoj * p->phase_viscosity[phj];
  (void)d;
  return mj * (mui + muj) * (F * r2) / (rhoi * rhoj * (r2 + eta2)) * vij;
#else
  (void)mui;
  const float vx = fmin(dot(vij, d), 0.0f); /* approaching pairs only; branch-free */
  /* Pi_ij with mu_ij folded in: one division per pair */
  const float Pi = -p->alpha * p->c0 * p->h * vx / ((r2 + eta2) * (0.5f * (rhoi + rhoj)));
  return -mj * Pi * F * d;
#endif
}

#endif
#endif
