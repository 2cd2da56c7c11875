#!/usr/bin/python3
"""The sampled surface's closure G of a ball, per frame (docs/forces.md, session 32).

Usage: closure.py RUN_DIR DX [EVERY]
RUN_DIR: a `sphaptics run` output with `output.particles: true` (particles.h5part holds the fluid,
type 0, and the ball's particles, type 2); one moving body, a sphere of radius R = 0.03 m.
For each frame it prints the ball's centre height, the mean fluid pressure p_c within H of the ball,
G_z = sum_b sum_i psi_b 2 / delta_i^2 dW/dz (N/Pa: the force per pascal added to every pressure) and
p_c G_z. psi_b comes from the ball's own particles (Akinci: 1 / sum W over them, over dx^3), without
compile's volume scale, so the forces are ~2x the code's; G's sign and growth are what it shows.
The cubic spline with support H = 2 dx, as kernels/shared/pair_loops.h.
"""
import sys
import h5py
import numpy as np

out, dx = sys.argv[1], float(sys.argv[2])
every = int(sys.argv[3]) if len(sys.argv) > 3 else 5
H, radius = 2 * dx, 0.03
mass = 1000 * dx ** 3


def grad_factor(r):
    q = r / H
    s = 8 / np.pi / H ** 3
    inner = 18 * q - 12
    outer = -6 * (1 - q) ** 2 / np.maximum(q, 0.25)
    return np.where(q <= 0.5, inner, np.where(q < 1, outer, 0.0)) * s / H ** 2


def kernel(r):
    q = r / H
    s = 8 / np.pi / H ** 3
    return np.where(q <= 0.5, s * (6 * q ** 3 - 6 * q ** 2 + 1), np.where(q < 1, s * 2 * (1 - q) ** 3, 0.0))


f = h5py.File(out + "/particles.h5part", "r")
keys = sorted(f.keys(), key=lambda s: int(s.split("#")[1]))
psi = None
print("t_s z_c_m p_c_Pa G_z_N_per_Pa p_c_G_z_N")
for key in keys[::every]:
    g = f[key]
    kind = g["type"][:]
    x = np.stack([g["x"][:], g["y"][:], g["z"][:]], 1)
    fluid, ball = kind == 0, kind == 2
    xb, xf = x[ball], x[fluid]
    pf, delta = g["pressure"][:][fluid], g["density"][:][fluid] / mass
    if psi is None:
        psi = 1.0 / kernel(np.linalg.norm(xb[:, None] - xb[None], axis=2)).sum(1) / dx ** 3
    c = xb.mean(0)
    dist = np.linalg.norm(xf - c, axis=1)
    near = dist < radius + H + dx
    d = xf[near][None] - xb[:, None]
    coef = psi[:, None] * 2.0 / delta[near][None] ** 2 * grad_factor(np.linalg.norm(d, axis=2))
    gz = (coef * d[:, :, 2]).sum()
    pc = pf[dist < radius + H].mean()
    print("%.3f %.4f %.0f %.3e %.3f" % (g.attrs["TimeValue"], c[2], pc, gz, pc * gz))
