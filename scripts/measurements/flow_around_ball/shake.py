#!/usr/bin/env python3
"""Shaken ball (accel_ball.yaml, run with particles): force-based C_m and the flow's dipole strength from the
same run (session 14 helper). Path x = x0 + A (1 - cos w t'), t' = t - 0.3 s, A = 1 mm, w = 2 pi 10 Hz.
Force: forces.csv F_x = c + B v(t) - C_m rho V a(t - tau) over 0.3-0.5 s, exact v, a.
Flow: fluid velocity at R < r < 2R fitted over all frames in 0.3-0.5 s as u = alpha Phi v(t) + beta Phi a(t)/w,
Phi the potential flow of a sphere of radius R per unit speed; alpha = 1 for potential flow, lag = -beta/(w alpha).
usage: shake.py RUN_DIR"""
import sys, csv, json, numpy as np, h5py
d = sys.argv[1]; R = 0.03; rho = 1000.0; V = 4 / 3 * np.pi * R**3; A = 1e-3; w = 2 * np.pi * 10
v_ = lambda t: np.where(t >= 0.3, A * w * np.sin(w * (t - 0.3)), 0.0)
a_ = lambda t: np.where(t >= 0.3, A * w * w * np.cos(w * (t - 0.3)), 0.0)
rows = [l for l in open(d + "/forces.csv") if not l.startswith("#")]
hdr = rows[0].strip().split(","); ix = {c: i for i, c in enumerate(hdr)}
T = np.array([float(l.split(",")[ix["time"]]) for l in rows[1:]]); F = np.array([float(l.split(",")[ix["fluid_fx"]]) for l in rows[1:]])
dt = np.median(np.diff(T))
VX = np.array([float(l.split(",")[ix["vx"]]) for l in rows[1:]])
# the check's own estimator (cli/force_checks.cpp acceleratedBall): a by central differences of the logged v
ac = np.zeros_like(T); ac[1:-1] = (VX[2:] - VX[:-2]) / (T[2:] - T[:-2])
mk = np.zeros_like(T, bool); mk[1:-1] = True; mk &= (T >= 0.3) & (T <= 0.5)
Mk = np.stack([ac[mk], VX[mk]], 1); ck, *_ = np.linalg.lstsq(Mk, F[mk], rcond=None)
check_cm = -ck[0] / (rho * V)
wm = (T >= 0.3) & (T <= 0.5)
print(f"{d}: {len(T)} steps, dt {dt*1e3:.2f} ms; the check's estimator C_m {check_cm:.4f}")
for tau in (0.0, 0.0025, 0.005):
    M = np.stack([np.ones(wm.sum()), v_(T[wm]), -rho * V * a_(T[wm] - tau)], 1)
    cf, *_ = np.linalg.lstsq(M, F[wm], rcond=None)
    print(f"  force: lag {tau*1e3:.1f} ms: C_m {cf[2]:.3f}  B {cf[1]:.3f} N s/m")
B = {}
for r in csv.DictReader([r for r in open(d + "/bodies.csv") if not r.startswith("#")]):
    B[round(float(r["time"]), 6)] = np.array([float(r["com_x"]), float(r["com_y"]), float(r["com_z"])])
f = h5py.File(d + "/particles.h5part", "r")
sect = {"all": lambda c: np.ones_like(c, bool), "front": lambda c: c > 0.5, "side": lambda c: np.abs(c) <= 0.5, "back": lambda c: c < -0.5, "front30": lambda c: c > 0.866, "back30": lambda c: c < -0.866}
G = {s: np.zeros((2, 2)) for s in sect}; bvec = {s: np.zeros(2) for s in sect}
for k in f:
    if not k.startswith("Step#"): continue
    g = f[k]; t = float(g.attrs["TimeValue"])
    if not (0.3 < t <= 0.5 + 1e-9): continue
    sel = g["type"][()] == 0
    X = np.stack([g["x"][()], g["y"][()], g["z"][()]], 1)[sel].astype(float)
    U3 = np.stack([g["velocity_0"][()], g["velocity_1"][()], g["velocity_2"][()]], 1)[sel].astype(float)
    c = B[round(t, 6)]; s = X - c; r = np.linalg.norm(s, axis=1); cs = s[:, 0] / r
    nn = (r < 2 * R) & (r > 0.9 * R)
    e = np.array([1.0, 0, 0]); Phi = R**3 * (3 * cs[:, None] * (s / r[:, None]) - e) / (2 * r[:, None]**3)
    vv, aa = float(v_(np.array(t))), float(a_(np.array(t))) / w
    for sn, sf in sect.items():
        m_ = nn & sf(cs)
        P = Phi[m_]; u = U3[m_]
        pp = (P * P).sum()
        G[sn] += np.array([[vv * vv, vv * aa], [vv * aa, aa * aa]]) * pp
        bvec[sn] += np.array([vv, aa]) * (P * u).sum()
for sn in sect:
    al, be = np.linalg.solve(G[sn], bvec[sn])
    print(f"  flow {sn:5s}: alpha {al:.3f}  beta {be:+.3f}  lag {-be/(w*al)*1e3:+.1f} ms")
