/* Colour diffusion between particles (stage: colour_diffusion, only when the coefficient D > 0).
 * Brookshaw (1985) SPH Laplacian: dc_i/dt = D * 2 sum_j (1/delta_j) (c_i - c_j) (x_ij . grad W_ij) / (|x_ij|^2 + 0.01 h^2)
 * Explicit update into a second buffer (the host swaps), so every particle reads old colours. */
__kernel void colour_diffuse(const SimParams p, __global const float4* pos, __global const uint* phase,
                             __global const float* density, __global const float4* colour,
                             __global const uint* nbr, __global const uint* nbr_count, __global float4* colour_out) {
  const uint i = get_global_id(0);
  if (i >= p.n_fluid) return;
  const float3 xi = pos[i].xyz;
  const float4 ci = colour[i];
  const float H = p.support;
  const float H2 = H * H;
  const float eta2 = 0.01f * p.h * p.h;
  float4 lap = (float4)(0.0f);
  const uint nn = nbr_count[i];
  const SphList list = sph_list(&p, nbr, i); /* narrow or wide (shared/neighbours.h) */
  for (uint k = 0; k < nn; ++k) {
    const uint j = sph_list1(list, k);
    const float3 d = xi - pos[j].xyz;
    const float r2 = dot(d, d);
    if (r2 < H2) {
      const float dj = density[j] / p.phase_mass[phase[j]];
      const float F = sph_grad_factor(SPH_KERNEL, sqrt(r2), H);
      lap += 2.0f / dj * (ci - colour[j]) * (F * r2) / (r2 + eta2);
    }
  }
  float4 c = ci + p.dt * p.colour_diffusion * lap;
  c.w = ci.w;
  colour_out[i] = clamp(c, 0.0f, 1.0f);
}
