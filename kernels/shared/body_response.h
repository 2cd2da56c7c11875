/* How a rigid body moves under the fluid's pressure inside DFSPH's solves (the strong body
 * coupling: kernels/dfsph.cl, dfsph_body_accel; the coarse level: kernels/dfsph_coarse.cl), per moving
 * body DFSPH_BODY_STRIDE float4 from the host (Simulation::bodyResponse, from rigid::mobility):
 *   [0]          (c, free): the centre of mass (unit: m); free = 1 for a body that moves in the
 *                solves, 0 for one that does not (held before its release, kinematic)
 *   [1]          (a_dry, R): the centre's acceleration without the fluid's pressure (gravity, the last
 *                step's contact forces and this step's external wrench) (unit: m/s^2); R the body's
 *                reach (its error's rotation part) (unit: m)
 *   [2]          (alpha_dry, 0): the same for the rotation (unit: 1/s^2)
 *   [3 + 2i], [4 + 2i], i = 0..5: row i of the body's mobility N, (a, alpha) = N (F, T): its F part
 *                and its T part (unit: 1/kg, 1/(kg m), 1/(kg m^2)).
 * A free body's N is diag(1 / m, I_w^-1); a body held by a haptic grab has the grab's spring-damper
 * implicit in it, N = (M + dt D)^-1 (core/rigid.h, BodyState::external_damping), which couples its
 * translation and rotation (a force at the grasp point's far side turns it about the grasp). Shared
 * by the host (the stride) and OpenCL C (the product). */
#ifndef SPHAPTICS_BODY_RESPONSE_H
#define SPHAPTICS_BODY_RESPONSE_H

#define DFSPH_BODY_STRIDE 16

#ifdef __OPENCL_VERSION__

/* (a, alpha) = N (F, T) for body b (unit: m/s^2, 1/s^2). */
inline void dfsph_body_mobility(__global const float4* data, const uint b, const float3 F, const float3 T, float3* a,
                                float3* al) {
  __global const float4* n = data + (size_t)b * DFSPH_BODY_STRIDE + 3;
  *a = (float3)(dot(n[0].xyz, F) + dot(n[1].xyz, T), dot(n[2].xyz, F) + dot(n[3].xyz, T),
                dot(n[4].xyz, F) + dot(n[5].xyz, T));
  *al = (float3)(dot(n[6].xyz, F) + dot(n[7].xyz, T), dot(n[8].xyz, F) + dot(n[9].xyz, T),
                 dot(n[10].xyz, F) + dot(n[11].xyz, T));
}

#endif
#endif
