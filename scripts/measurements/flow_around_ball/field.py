#!/usr/bin/env python3
"""Ball-frame mean velocity field (lab-frame velocity / U) of a towed ball, binned in r/R and theta
(angle from the direction of motion), axial u_x and radial (away from the line of motion) components,
against the potential flow of a sphere of radius R at the same particles. usage: field.py RUN_DIR [t0 t1]"""
import sys, numpy as np, h5py
from common import ball_track
d = sys.argv[1]; t0 = float(sys.argv[2]) if len(sys.argv) > 2 else 0.37; t1 = float(sys.argv[3]) if len(sys.argv) > 3 else 0.555
R = 0.03
B = ball_track(d)
f = h5py.File(d + "/particles.h5part", "r")
re_ = np.array([1.0, 1.2, 1.4, 1.7, 2.0, 2.5, 3.0, 4.0]); te = np.arange(0, 181, 30)
S = {k: np.zeros((len(re_) - 1, len(te) - 1)) for k in ("n", "ua", "ur", "pa", "pr", "ua2", "ur2")}
for k in f:
    if not k.startswith("Step#"): continue
    g = f[k]; t = float(g.attrs["TimeValue"])
    if not (t0 - 1e-9 <= t <= t1 + 1e-9): continue
    sel = g["type"][()] == 0
    X = np.stack([g["x"][()], g["y"][()], g["z"][()]], 1)[sel].astype(float)
    U3 = np.stack([g["velocity_0"][()], g["velocity_1"][()], g["velocity_2"][()]], 1)[sel].astype(float)
    c, Ub = B[round(t, 6)]
    s = X - c; r = np.linalg.norm(s, axis=1) / R; cs = s[:, 0] / (r * R); th = np.degrees(np.arccos(np.clip(cs, -1, 1)))
    rc = np.sqrt(s[:, 1]**2 + s[:, 2]**2) + 1e-30
    ua = U3[:, 0] / Ub; ur = (U3[:, 1] * s[:, 1] + U3[:, 2] * s[:, 2]) / rc / Ub
    q = 1 / (2 * r**3); pa = q * (3 * cs * cs - 1); pr = q * 3 * cs * (rc / (r * R))
    i = np.digitize(r, re_) - 1; j = np.clip(np.digitize(th, te) - 1, 0, len(te) - 2)
    ok = (i >= 0) & (i < len(re_) - 1) & (r > 0.9)
    for key, val in (("n", 1.0 + 0 * r), ("ua", ua), ("ur", ur), ("pa", pa), ("pr", pr), ("ua2", ua * ua), ("ur2", ur * ur)):
        np.add.at(S[key], (i[ok], j[ok]), val[ok])
n = np.maximum(S["n"], 1)
print(f"{d}: mean u_x/U and u_radial/U, SPH [potential flow], +- standard error if frames were independent; rows r/R, columns theta (deg from the front)")
print("r/R \\ th  " + "".join(f"{te[j]:>3d}-{te[j+1]:<3d}                      " for j in range(len(te) - 1)))
for i in range(len(re_) - 1):
    line = f"{re_[i]:.1f}-{re_[i+1]:.1f}  "
    for j in range(len(te) - 1):
        ua = S["ua"][i, j] / n[i, j]; ur = S["ur"][i, j] / n[i, j]
        line += f"{ua:+.2f}[{S['pa'][i,j]/n[i,j]:+.2f}] {ur:+.2f}[{S['pr'][i,j]/n[i,j]:+.2f}]   "
    print(line)
