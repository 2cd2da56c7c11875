#!/usr/bin/env python3
"""Shaken ball (session 15): the body's pair terms recomputed from a run's frames, and what they give for the
potential flow's pressure.

usage: bodyop.py RUN_DIR [--t0 0.3 --t1 0.5]
Per step k -> k+1 (one frame per step): body particles x_b and fluid x_i at frame k, pressures/densities of frame k+1.
  F_b,x = sum_b sum_{i within H} psi_b (p_i + p_b) / delta_i^2 F(r) (x_i - x_b)_x      (rigid.cl, WCSPH and DFSPH's
          extrapolated walls; no contact term), p_b = max(0, (sum_i p_i W_bi + g . sum_i rho_i (x_b - x_i) W_bi) / sum W_bi)
  psi_b = c / (V0 sum_k W(x_b - x_k)) over the body's particles (Akinci), c fitted once against forces.csv.
Printed: the fit (c, correlation with forces.csv), then the same operator with the potential-flow pressure of a sphere
accelerating at a = 1 m/s^2 (p_pot = rho0 a (x - c)_x R^3 / (2 r^3), hydrostatics left out):
  (i) p_b extrapolated from p_pot as the code does, (ii) p_b = p_pot(x_b), (iii) p_b = p_i (mirrored),
  (iv) the fluid pressure alone (p_b = 0); each as -F_x / (rho0 V a): the continuum's is 1/2 (unbounded).
"""
import sys, json, argparse, numpy as np, h5py
from scipy.spatial import cKDTree
from common import ball_track

ap = argparse.ArgumentParser()
ap.add_argument("run")
ap.add_argument("--t0", type=float, default=0.3)
ap.add_argument("--t1", type=float, default=0.5)
a = ap.parse_args()
d = a.run
R = 0.03; rho0 = 1000.0; V = 4 / 3 * np.pi * R**3; g = 9.81
dx = json.load(open(d + "/run.json"))["scene"]["fluid"]["particle_spacing"]; H = 2 * dx; m = rho0 * dx**3; V0 = dx**3
track = ball_track(d)
fb = {}
rows = [r for r in open(d + "/forces.csv") if not r.startswith("#")]
hdr = rows[0].strip().split(",")
for r in rows[1:]:
    s = r.strip().split(","); fb[round(float(s[0]), 7)] = float(s[hdr.index("fluid_fx")])


def W(r):
    q = r / H; s = 8 / np.pi / H**3; t = np.maximum(1 - q, 0)
    return s * np.where(q <= 0.5, 6 * q**3 - 6 * q**2 + 1, 2 * t**3)


def gradF(r):
    q = r / H; s = 8 / np.pi / H**3; t = np.maximum(1 - q, 0); qs = np.maximum(q, 0.25)
    return s * np.where(q <= 0.5, 18 * q - 12, -6 * t * t / qs) / H**2


f = h5py.File(d + "/particles.h5part", "r")
steps = sorted((float(f[k].attrs["TimeValue"]), k) for k in f if k.startswith("Step#"))
code, ref, pots, rbs = [], [], [], []
prev = None
for t, k in steps:
    if t < a.t0 - 1e-9 or t > a.t1 + 1e-9:
        continue
    gk = f[k]
    if prev is None:
        prev = (t, gk); continue
    tk, g0 = prev; prev = (t, gk)
    ty0 = g0["type"][()]; ty1 = gk["type"][()]
    id0 = g0["id"][()]; id1 = gk["id"][()]
    X = np.stack([g0["x"][()], g0["y"][()], g0["z"][()]], 1).astype(float)
    fl0 = np.where(ty0 == 0)[0]; fl1 = np.where(ty1 == 0)[0]
    o0 = fl0[np.argsort(id0[fl0])]; o1 = fl1[np.argsort(id1[fl1])]
    Xf = X[o0]; P = gk["pressure"][()][o1].astype(float); RHO = gk["density"][()][o1].astype(float)
    Xb = X[ty0 == 2]
    c = track[round(tk, 6)][0]
    # Akinci volumes (up to the fitted constant)
    tb = cKDTree(Xb); sb = np.zeros(len(Xb))
    for i, js in enumerate(tb.query_ball_point(Xb, H)):
        sb[i] = W(np.linalg.norm(Xb[js] - Xb[i], axis=1)).sum()
    psi0 = 1.0 / (V0 * sb)
    tf = cKDTree(Xf)
    pairs = tf.query_ball_point(Xb, H)
    sf = Xf - c; rf = np.linalg.norm(sf, axis=1)
    ppot = rho0 * 1.0 * sf[:, 0] * R**3 / (2 * rf**3)
    sbc = Xb - c; rb = np.linalg.norm(sbc, axis=1); ppot_b = rho0 * sbc[:, 0] * R**3 / (2 * rb**3)
    Fc = 0.0; Fp = np.zeros(5)
    for b, js in enumerate(pairs):
        js = np.array(js)
        if len(js) == 0: continue
        dv = Xf[js] - Xb[b]; r = np.linalg.norm(dv, axis=1); w = W(r); Fg = gradF(r)
        inv_d2 = (m / RHO[js])**2
        pb = (np.sum(P[js] * w) + np.dot(np.array([0, 0, -g]), np.sum(RHO[js][:, None] * (Xb[b] - Xf[js]) * w[:, None], 0))) / w.sum()
        pb = max(pb, 0.0)
        Fc += psi0[b] * np.sum((P[js] + pb) * inv_d2 * Fg * dv[:, 0])
        pbe = np.sum(ppot[js] * w) / w.sum()
        pba = pbe - rho0 * np.sum((Xb[b][0] - Xf[js][:, 0]) * w) / w.sum()  # Adami's a_w term, a_w = (1, 0, 0) m/s^2
        for q, pbq in enumerate((pbe, ppot_b[b], None, 0.0, pba)):
            pbv = ppot[js] if pbq is None else pbq
            Fp[q] += psi0[b] * np.sum((ppot[js] + pbv) * inv_d2 * Fg * dv[:, 0])
    rbs.append(rb.mean())
    code.append(Fc); ref.append(fb[round(tk, 7)]); pots.append(Fp)
code = np.array(code); ref = np.array(ref); pots = np.array(pots)
# fit c: ref = c * code (+ const: the hydrostatic force is along z, so none in x)
cc = np.dot(code, ref) / np.dot(code, code)
res = ref - cc * code
print(f"{d}: {len(ref)} steps; psi constant c = {cc:.4f}; forces.csv F_x rms {np.std(ref):.4f} N, residual rms {np.std(res):.4f} N, corr {np.corrcoef(code, ref)[0, 1]:.4f}; body particles at r = {np.mean(rbs) / R:.4f} R")
for q, name in enumerate(("p_b extrapolated (the code)", "p_b = p_pot(x_b)", "p_b = p_i (mirrored)", "fluid p only (p_b = 0)", "p_b extrapolated with Adami's a_w term")):
    val = -cc * pots[:, q] / (rho0 * V * 1.0)
    print(f"  potential-flow pressure, {name}: -F_x / (rho V a) = {val.mean():.3f} (+- {val.std():.3f} over steps)")
