#!/usr/bin/env python3
"""Early frames of a tow (session 14 helper): the field u_tow - u_rest (same particle ids; the runs are identical
to 0.3 s and the particle noise has not yet decorrelated), its KE near the ball (r < 3R) against the potential
flow's at the same particles, its projection k on the potential flow (r < 2R), and its KE over the whole tank.
usage: early.py TOW_DIR REST_DIR"""
import sys, csv, numpy as np, h5py
d, dr = sys.argv[1], sys.argv[2]; R = 0.03; rho = 1000.0; V = 4 / 3 * np.pi * R**3
import json; dx = json.load(open(d + "/run.json"))["scene"]["fluid"]["particle_spacing"]; m = rho * dx**3
B = {}
for r in csv.DictReader([r for r in open(d + "/bodies.csv") if not r.startswith("#")]):
    B[round(float(r["time"]), 6)] = (np.array([float(r["com_x"]), float(r["com_y"]), float(r["com_z"])]), float(r["vx"]))
f = h5py.File(d + "/particles.h5part", "r"); fr = h5py.File(dr + "/particles.h5part", "r")
def load(g):
    sel = g["type"][()] == 0; ids = g["id"][()][sel]; o = np.argsort(ids)
    X = np.stack([g["x"][()], g["y"][()], g["z"][()]], 1)[sel][o].astype(float)
    U3 = np.stack([g["velocity_0"][()], g["velocity_1"][()], g["velocity_2"][()]], 1)[sel][o].astype(float)
    return X, U3
def forces(dd):
    rows = [l for l in open(dd + "/forces.csv") if not l.startswith("#")]; h = rows[0].strip().split(","); ix = {c: i for i, c in enumerate(h)}
    return np.array([[float(l.split(",")[ix["time"]]), float(l.split(",")[ix["vx"]]), float(l.split(",")[ix["fluid_fx"]])] for l in rows[1:]])
Ft = forces(d); Fr = forces(dr)
dF = Ft[:, 2] - np.interp(Ft[:, 0], Fr[:, 0], Fr[:, 2])
dts = np.diff(np.append(Ft[:, 0], Ft[-1, 0] + (Ft[-1, 0] - Ft[-2, 0])))
Wcum = np.cumsum(-dF * Ft[:, 1] * dts)   # work done by the ball on the fluid (tow minus held), to the end of each step
print(f"{d} - {dr}  (dx {dx})\n   t     U_ball   k(r<2R)  C_m near: diff [pot.flow]   C_m whole tank (diff)   work by the ball / (1/2 rho V U^2)")
for i in range(31, 56):
    k = f"Step#{i}"
    if k not in f: break
    g = f[k]; t = float(g.attrs["TimeValue"]); c, Ub = B[round(t, 6)]
    X, U1 = load(g); _, U2 = load(fr[k]); du = U1 - U2
    s = X - c; r = np.linalg.norm(s, axis=1); cs = s[:, 0] / r; e = np.array([1.0, 0, 0])
    up = Ub * R**3 * (3 * cs[:, None] * (s / r[:, None]) - e) / (2 * r[:, None]**3)
    out_ = r > R - dx / 2  # fluid that leaked inside the ball (R/dx 5) left out
    n2 = (r < 2 * R) & out_; n3 = (r < 3 * R) & out_
    kk = (du[n2] * up[n2]).sum() / (up[n2]**2).sum()
    nrm = 0.5 * rho * V * Ub**2
    print(f"{t:.3f} {Ub:.4f}  {kk:6.3f}   {0.5*m*(du[n3]**2).sum()/nrm:7.3f} [{0.5*m*(up[n3]**2).sum()/nrm:.3f}]   {0.5*m*(du[out_]**2).sum()/nrm:8.3f}   {np.interp(t, Ft[:, 0] + dts, Wcum)/nrm:8.3f}")
