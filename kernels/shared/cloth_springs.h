/* sphaptics: a cloth spring's stiffness over one step, shared by kernels/cloth.cl (cloth_node_response)
 * and kernels/dfsph.cl (dfsph_node_accel), the two halves of DFSPH's strong cloth coupling.
 * For a spring of parameters q = (rest length L0, stiffness k, dashpot c, tear strain) at length L,
 * its step stiffness is K_e = ax u u^T + tr (I - u u^T) (unit: kg), with
 *   ax = dt c + dt^2 k             along the spring (dashpot and spring implicit over dt),
 *   tr = dt^2 max(T, 0) / L        across it, T = k (L - L0) the tension (a stretched string's
 *                                  stiffness across itself; a slack one has none).
 * Returns (ax, tr). */
#ifndef SPHAPTICS_CLOTH_SPRINGS_H
#define SPHAPTICS_CLOTH_SPRINGS_H

inline float2 cloth_spring_step_stiffness(const float4 q, const float L, const float dt) {
  return (float2)(dt * q.z + dt * dt * q.y, dt * dt * fmax(q.y * (L - q.x), 0.0f) / L);
}

#endif
