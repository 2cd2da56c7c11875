#!/usr/bin/env python3
"""Fluid kinetic energy and near field of a towed ball (session 14 helper).
usage: ke.py TOW_DIR REST_DIR U DX [--t0 0.37] [--t1 0.55]
Reads particles.h5part (fluid = type 0, mass rho0 dx^3) and bodies.csv (the ball's centre).
Prints per frame: KE_tow, KE_rest, KE of (u_tow - u_rest) matched by id, and C_m from each;
then the near-field fit of u_tow - u_rest against the potential flow of a sphere of radius R."""
import sys, argparse, numpy as np, h5py, csv
ap = argparse.ArgumentParser()
ap.add_argument("tow"); ap.add_argument("rest"); ap.add_argument("U", type=float); ap.add_argument("dx", type=float)
ap.add_argument("--t0", type=float, default=0.37); ap.add_argument("--t1", type=float, default=0.555)
ap.add_argument("--R", type=float, default=0.03); ap.add_argument("--rho", type=float, default=1000.0)
ap.add_argument("--frames", action="store_true", help="print every frame")
ap.add_argument("--field", default="", help="write the per-shell field table to this file")
a = ap.parse_args()
R, rho, U, dx = a.R, a.rho, a.U, a.dx
V = 4.0 / 3.0 * np.pi * R**3
m = rho * dx**3
norm = 0.5 * rho * V * U**2   # KE of C_m = 1

def bodies(d):
    out = {}
    with open(d + "/bodies.csv") as f:
        rows = [r for r in f if not r.startswith("#")]
    rd = csv.DictReader(rows)
    for r in rd:
        out[round(float(r["time"]), 6)] = (np.array([float(r["com_x"]), float(r["com_y"]), float(r["com_z"])]),
                                           np.array([float(r["vx"]), float(r["vy"]), float(r["vz"])]))
    return out

def frames(fn):
    f = h5py.File(fn, "r")
    ks = sorted([k for k in f.keys() if k.startswith("Step#")], key=lambda k: int(k[5:]))
    return f, ks

def load(g):
    t = g["type"][()] if "type" in g else np.zeros(len(g["x"]))
    sel = t == 0
    X = np.stack([g["x"][()], g["y"][()], g["z"][()]], 1)[sel]
    Vv = np.stack([g["velocity_0"][()], g["velocity_1"][()], g["velocity_2"][()]], 1)[sel]
    ids = g["id"][()][sel]
    o = np.argsort(ids)
    return X[o].astype(float), Vv[o].astype(float), ids[o]

bt = bodies(a.tow)
ft, kt = frames(a.tow + "/particles.h5part")
fr, kr = frames(a.rest + "/particles.h5part")
rows = []
# near-field accumulators: shells in r/R, sectors front (cos > 0.5) / equator / back (cos < -0.5)
shells = [(1.0, 1.2), (1.2, 1.4), (1.4, 1.7), (1.7, 2.2), (2.2, 3.0)]
sectors = ["front", "equator", "back", "all"]
acc = {(s, c): np.zeros(4) for s in range(len(shells)) for c in sectors}   # sum du.upf, sum upf.upf, n, sum |du|^2
acc_ax = {}
pf_cm = []; rmin = []
for k1, k2 in zip(kt, kr):
    g1, g2 = ft[k1], fr[k2]
    t = float(g1.attrs["TimeValue"])
    X1, V1, i1 = load(g1); X2, V2, i2 = load(g2)
    assert np.array_equal(i1, i2)
    ke1 = 0.5 * m * (V1**2).sum(); ke2 = 0.5 * m * (V2**2).sum()
    dV = V1 - V2
    ked = 0.5 * m * (dV**2).sum()
    c, vb = bt[round(t, 6)]
    Ub = vb[0]
    rows.append((t, Ub, ke1, ke2, ked))
    if a.t0 <= t <= a.t1 and Ub > 0:
        rr = X1 - c; r = np.linalg.norm(rr, axis=1); rh = rr / r[:, None]
        e = np.array([1.0, 0, 0]); cs = rh @ e
        upf = Ub * R**3 * (3 * cs[:, None] * rh - e) / (2 * r[:, None]**3)
        pf_cm.append(0.5 * m * (upf**2).sum() / (0.5 * rho * V * Ub**2))
        rmin.append(r.min())
        for si, (lo, hi) in enumerate(shells):
            inshell = (r >= lo * R) & (r < hi * R)
            for cname in sectors:
                sel = inshell & ({"front": cs > 0.5, "back": cs < -0.5, "equator": np.abs(cs) <= 0.5, "all": np.ones_like(cs, bool)}[cname])
                acc[(si, cname)] += [(dV[sel] * upf[sel]).sum(), (upf[sel]**2).sum(), sel.sum(), (dV[sel]**2).sum()]
rows = np.array(rows)
t, Ub, ke1, ke2, ked = rows.T
if a.frames:
    print("   t      U_ball   KE_tow(J)  KE_rest(J)  KE_diff(J)  Cm(tow-rest) Cm(diff)")
    for r_ in rows:
        print(f"{r_[0]:.3f} {r_[1]:.5f} {r_[2]:.3e} {r_[3]:.3e} {r_[4]:.3e} {(r_[2]-r_[3])/norm:8.3f} {r_[4]/norm:8.3f}")
w = (t >= a.t0) & (t <= a.t1)
cm_sub = (ke1[w] - ke2[w]) / (0.5 * rho * V * Ub[w]**2)
cm_diff = ked[w] / (0.5 * rho * V * Ub[w]**2)
rest_ke = ke2[(t >= 0.2) & (t <= 0.3)].mean()
def blk(x, nb=4):
    b = np.array_split(x, nb); mm = np.array([q.mean() for q in b]); return x.mean(), mm.std(ddof=1) / np.sqrt(nb), mm
ms, es, bs = blk(cm_sub); md, ed, bd = blk(cm_diff)
print(f"U={U} dx={dx} frames {w.sum()} in [{a.t0},{a.t1}]  KE_rest(0.2-0.3 s) = {rest_ke:.3e} J = {rest_ke/norm:.3f} x (1/2 rho V U^2)")
print(f"Cm from KE_tow - KE_rest : {ms:.4f} +- {es:.4f}   block means {np.round(bs,4)}")
print(f"Cm from KE(u_tow - u_rest): {md:.4f} +- {ed:.4f}   block means {np.round(bd,4)}")
print(f"potential flow of radius R (unbounded) sampled at the fluid particles: C_m {np.mean(pf_cm):.4f} (closed form 0.5); nearest fluid particle r/R = {np.min(rmin)/R:.3f}, {np.min(rmin)/dx - R/dx:+.2f} dx from R")
out = []
print("near field of u_tow - u_rest against potential flow (radius R): k = sum du.upf / sum upf^2, R_eff/R = k^(1/3); rms ratio = sqrt(sum du^2 / sum upf^2)")
print("shell r/R    " + "  ".join(f"{c:>20s}" for c in sectors))
for si, (lo, hi) in enumerate(shells):
    parts = []
    for cname in sectors:
        s1, s2, n, s3 = acc[(si, cname)]
        k = s1 / s2 if s2 > 0 else np.nan
        parts.append(f"k {k:5.2f} rms {np.sqrt(s3/s2) if s2>0 else np.nan:5.2f} n{int(n/ max(1,w.sum())):4d}")
        out.append((lo, hi, cname, k))
    print(f"{lo:.1f}-{hi:.1f}  " + "  ".join(parts))
