#!/usr/bin/env python3
"""Shaken ball: x-momentum of the fluid within r < 2R and r < 3R of the ball, fitted over 0.3-0.5 s as
P(t) = c + p_v rho V v(t) + p_a rho V a(t)/w; the same for the potential flow of radius R sampled at the same
particles (ideal: ~0, the dipole's x-velocity averages to zero over whole shells). usage: shellmom.py RUN_DIR"""
import sys, json, numpy as np, h5py
from common import ball_track, shaken_path
d = sys.argv[1]; R = 0.03; rho = 1000.0; V = 4 / 3 * np.pi * R**3; A = 1e-3; w = 2 * np.pi * 10
dx = json.load(open(d + "/run.json"))["scene"]["fluid"]["particle_spacing"]; m = rho * dx**3
v_, a_ = shaken_path(A, 10.0)
B = {t: c for t, (c, _) in ball_track(d).items()}
f = h5py.File(d + "/particles.h5part", "r")
rows = []
for k in f:
    if not k.startswith("Step#"): continue
    g = f[k]; t = float(g.attrs["TimeValue"])
    if not (0.3 < t <= 0.5 + 1e-9): continue
    sel = g["type"][()] == 0
    X = np.stack([g["x"][()], g["y"][()], g["z"][()]], 1)[sel].astype(float); ux = g["velocity_0"][()][sel].astype(float)
    c = B[round(t, 6)]; s = X - c; r = np.linalg.norm(s, axis=1); cs = s[:, 0] / r
    phx = R**3 * (3 * cs * cs - 1) / (2 * r**3) * v_(t)
    row = [t]
    for rc in (2, 3):
        mm = (r > R - dx / 2) & (r < rc * R)
        row += [m * ux[mm].sum(), m * phx[mm].sum()]
    rows.append(row)
rows = np.array(rows); T = rows[:, 0]
M = np.stack([np.ones(len(T)), rho * V * np.array([v_(t) for t in T]), rho * V * np.array([a_(t) for t in T]) / w], 1)
for i, rc in enumerate((2, 3)):
    cs_, *_ = np.linalg.lstsq(M, rows[:, 1 + 2 * i], rcond=None); cp, *_ = np.linalg.lstsq(M, rows[:, 2 + 2 * i], rcond=None)
    print(f"{d}: r < {rc}R: P_x = {cs_[1]:+.3f} rho V v {cs_[2]:+.3f} rho V a/w  [potential flow, same particles: {cp[1]:+.3f} rho V v]")
