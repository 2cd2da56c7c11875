#!/usr/bin/env python3
"""Per-frame near-field measures of a towed ball (session 14 helper): k = projection of the velocity on the
potential flow over R < r < 2R; mean u_x/U in front (r < 2R, theta < 45), at the side (r < 1.4R, 60-120 deg),
behind (r < 2R, theta > 135), each with the potential flow's value at the same particles in [].
usage: tseries.py RUN_DIR [--fake-U U]"""
import sys, numpy as np, h5py
from common import ball_track
d = sys.argv[1]; fakeU = float(sys.argv[3]) if len(sys.argv) > 3 else 0
R = 0.03
B = ball_track(d)
f = h5py.File(d + "/particles.h5part", "r")
ks = sorted([k for k in f if k.startswith("Step#")], key=lambda k: int(k[5:]))
print(f"{d}\n   t     U      k(r<2R)   front u_x/U      side u_x/U       behind u_x/U")
for k in ks:
    g = f[k]; t = float(g.attrs["TimeValue"])
    c, Ub = B[round(t, 6)]
    if fakeU: Ub = fakeU
    if t < 0.3 or Ub <= 0: continue
    sel = g["type"][()] == 0
    X = np.stack([g["x"][()], g["y"][()], g["z"][()]], 1)[sel].astype(float)
    U3 = np.stack([g["velocity_0"][()], g["velocity_1"][()], g["velocity_2"][()]], 1)[sel].astype(float) / Ub
    s = X - c; r = np.linalg.norm(s, axis=1); cs = s[:, 0] / r; th = np.degrees(np.arccos(np.clip(cs, -1, 1)))
    e = np.array([1.0, 0, 0]); rh = s / r[:, None]
    up = R**3 * (3 * cs[:, None] * rh - e) / (2 * r[:, None]**3)
    n2 = (r < 2 * R) & (r > 0.9 * R)
    kk = (U3[n2] * up[n2]).sum() / (up[n2]**2).sum()
    out = []
    for m_ in (n2 & (th < 45), (r < 1.4 * R) & (r > 0.9 * R) & (th > 60) & (th < 120), n2 & (th > 135)):
        out.append(f"{U3[m_,0].mean():+.3f} [{up[m_,0].mean():+.3f}]")
    print(f"{t:.3f} {Ub:.4f}  {kk:6.3f}    " + "   ".join(out))
