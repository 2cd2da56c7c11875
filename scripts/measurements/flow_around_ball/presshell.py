#!/usr/bin/env python3
"""Shaken ball: the fluid's pressure dipole around the ball (session 14 helper). Per frame and radial shell,
p_i = c0 + cz s_z + D cos(theta)/r^2 by least squares over the shell's fluid particles (theta from +x);
then D(t) = K (rho R^3 / 2) a(t - tau) + L v(t) over 0.3-0.5 s with the path's exact a, v. Potential flow of a
sphere of radius R: p' = (rho/2) a R^3 cos(theta) / r^2, so K = 1 at every r (and the force on the ball is
-K (1/2) rho V a). usage: presshell.py RUN_DIR"""
import sys, numpy as np, h5py
from common import ball_track, shaken_path
d = sys.argv[1]; R = 0.03; rho = 1000.0; A = 1e-3; w = 2 * np.pi * 10
v_, a_ = shaken_path(A, 10.0)
B = {t: c for t, (c, _) in ball_track(d).items()}
f = h5py.File(d + "/particles.h5part", "r")
shells = [(1.0, 1.25), (1.25, 1.5), (1.5, 2.0), (2.0, 2.5)]
T = []; D = {s: [] for s in shells}
for k in f:
    if not k.startswith("Step#"): continue
    g = f[k]; t = float(g.attrs["TimeValue"])
    if not (0.25 <= t <= 0.5 + 1e-9): continue
    sel = g["type"][()] == 0
    X = np.stack([g["x"][()], g["y"][()], g["z"][()]], 1)[sel].astype(float); p = g["pressure"][()][sel].astype(float)
    c = B[round(t, 6)]; s = X - c; r = np.linalg.norm(s, axis=1)
    T.append(t)
    for (lo, hi) in shells:
        m = (r >= lo * R) & (r < hi * R)
        M = np.stack([np.ones(m.sum()), s[m, 2], s[m, 0] / r[m]**3], 1)
        cf, *_ = np.linalg.lstsq(M, p[m], rcond=None)
        D[(lo, hi)].append(cf[2])
T = np.array(T); mv = T >= 0.3
print(f"{d}: pressure dipole K (1 = potential flow of radius R), by lag of a(t - tau)")
for sh in shells:
    Dd = np.array(D[sh]); Dd = Dd - Dd[~mv].mean()   # the held ball's (0.25-0.3 s) dipole removed
    out = []
    for tau in (0.0, 0.0025, 0.005):
        Mx = np.stack([np.array([a_(t - tau) for t in T[mv]]) * rho * R**3 / 2, np.array([v_(t) for t in T[mv]])], 1)
        cf, *_ = np.linalg.lstsq(Mx, Dd[mv], rcond=None)
        out.append(f"tau {tau*1e3:.1f} ms: K {cf[0]:.3f} (L {cf[1]:+.2f})")
    print(f"  r/R {sh[0]:.2f}-{sh[1]:.2f}: " + "   ".join(out))
