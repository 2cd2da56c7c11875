#!/usr/bin/env python3
"""Coherent (ball-frame, phase-averaged) kinetic energy of the fluid around a towed ball, session 14 helper.
The inviscid tanks carry particle noise of ~6 cm/s rms (DFSPH, R/dx 3) at 'rest', ~100x the towed ball's KE at
5 cm/s, so the plain KE sum cannot see the ball. Here the velocity (divided by the ball's speed) is binned in the
ball's frame on (r, cos theta) about the line of motion (axisymmetric: axial and radial components), separately
for the first and second half of the tow's frames; KE = sum_bins 1/2 m n_b (uA . uB) with n_b the bin's mean
particle count per frame: the cross product of two independent halves has no noise bias.
The same estimator on the potential flow of a sphere of radius R (unbounded) evaluated at the same particles
gives the reference; their ratio Q (r < rmax) would be 1 for the exact flow.
usage: ke2.py RUN_DIR DX [--t0 0.37 --t1 0.555 --rmax 3 --fake-U U (for a run whose ball is still: null test)]"""
import argparse, csv, numpy as np, h5py
ap = argparse.ArgumentParser()
ap.add_argument("d"); ap.add_argument("dx", type=float)
ap.add_argument("--t0", type=float, default=0.37); ap.add_argument("--t1", type=float, default=0.555)
ap.add_argument("--rmax", type=float, default=3.0); ap.add_argument("--R", type=float, default=0.03)
ap.add_argument("--evenodd", action="store_true", help="cross even and odd frames instead of the two halves")
ap.add_argument("--fake-U", type=float, default=0.0); ap.add_argument("--ncos", type=int, default=16)
a = ap.parse_args()
R, dx, rho = a.R, a.dx, 1000.0
V = 4 / 3 * np.pi * R**3; m = rho * dx**3; norm1 = 0.5 * rho * V  # KE / (norm1 U^2) = C_m
B = {}
rows = [r for r in open(a.d + "/bodies.csv") if not r.startswith("#")]
for r in csv.DictReader(rows):
    B[round(float(r["time"]), 6)] = (np.array([float(r["com_x"]), float(r["com_y"]), float(r["com_z"])]), float(r["vx"]))
f = h5py.File(a.d + "/particles.h5part", "r")
ks = sorted([k for k in f if k.startswith("Step#")], key=lambda k: int(k[5:]))
redges = np.concatenate([[0.0], np.arange(R + dx / 2, a.rmax * R + 1e-9, dx / 2)])  # first bin: everything inside R + dx/2
redges[-1] = max(redges[-1], a.rmax * R)
cedges = np.linspace(-1, 1, a.ncos + 1)
nb = (len(redges) - 1) * a.ncos
def acc0(): return dict(n=np.zeros(nb), ua=np.zeros(nb), ur=np.zeros(nb), pa=np.zeros(nb), pr=np.zeros(nb), frames=0)
H = [acc0(), acc0()]
frames = [k for k in ks if a.t0 - 1e-9 <= float(f[k].attrs["TimeValue"]) <= a.t1 + 1e-9]
pf_exact = []; proj = {}
sectors = {"front": lambda c: c > 0.5, "equator": lambda c: np.abs(c) <= 0.5, "back": lambda c: c < -0.5}
shells = [(1.0, 1.25), (1.25, 1.5), (1.5, 2.0), (2.0, 3.0)]
for j, k in enumerate(frames):
    g = f[k]; t = float(g.attrs["TimeValue"])
    sel = g["type"][()] == 0
    X = np.stack([g["x"][()], g["y"][()], g["z"][()]], 1)[sel].astype(float)
    U3 = np.stack([g["velocity_0"][()], g["velocity_1"][()], g["velocity_2"][()]], 1)[sel].astype(float)
    c, Ub = B[round(t, 6)]
    if a.fake_U: Ub = a.fake_U
    s = X - c; r = np.linalg.norm(s, axis=1); cs = s[:, 0] / r
    rc = np.sqrt(s[:, 1]**2 + s[:, 2]**2) + 1e-30
    ua = U3[:, 0] / Ub; ur = (U3[:, 1] * s[:, 1] + U3[:, 2] * s[:, 2]) / rc / Ub
    # potential flow of radius R, unit U: u = R^3 (3 cos rhat - e) / (2 r^3)
    q = R**3 / (2 * r**3)
    pa = q * (3 * cs * cs - 1); pr = q * 3 * cs * (rc / r)
    pf_exact.append((0.5 * m * (pa**2 + pr**2)[(r < a.rmax * R) & (r > R - dx / 2)]).sum() / norm1)
    inn = (r < a.rmax * R) & (r > R - dx / 2)  # leaked fluid inside the ball left out
    bi = (np.digitize(r[inn], redges) - 1) * a.ncos + np.clip(np.digitize(cs[inn], cedges) - 1, 0, a.ncos - 1)
    h = H[(j % 2) if a.evenodd else (0 if j < len(frames) / 2 else 1)]
    h["frames"] += 1
    for key, val in (("n", np.ones(inn.sum())), ("ua", ua[inn]), ("ur", ur[inn]), ("pa", pa[inn]), ("pr", pr[inn])):
        h[key] += np.bincount(bi, weights=val, minlength=nb)
    for (lo, hi) in shells:
        for sn, sf in sectors.items():
            m_ = (r >= lo * R) & (r < hi * R) & sf(cs)
            p = proj.setdefault((lo, sn), np.zeros(3))
            p += [(ua * pa + ur * pr)[m_].sum(), (pa * pa + pr * pr)[m_].sum(), (ua * ua + ur * ur)[m_].sum()]
def mean(h, key):
    return np.where(h["n"] > 0, h[key] / np.maximum(h["n"], 1), 0.0)
nbar = (H[0]["n"] + H[1]["n"]) / (H[0]["frames"] + H[1]["frames"])
ok = (H[0]["n"] > 0) & (H[1]["n"] > 0)
cross = mean(H[0], "ua") * mean(H[1], "ua") + mean(H[0], "ur") * mean(H[1], "ur")
selfA = mean(H[0], "ua")**2 + mean(H[0], "ur")**2
pf = ((H[0]["pa"] + H[1]["pa"]) / np.maximum(H[0]["n"] + H[1]["n"], 1))**2 + ((H[0]["pr"] + H[1]["pr"]) / np.maximum(H[0]["n"] + H[1]["n"], 1))**2
ke_coh = (0.5 * m * nbar * cross)[ok].sum() / norm1
ke_self = (0.5 * m * nbar * selfA)[ok].sum() / norm1
ke_pf = (0.5 * m * nbar * pf)[ok].sum() / norm1
# per radial shell of the bins
rb = np.repeat(np.arange(len(redges) - 1), a.ncos)
print(f"{a.d}: {len(frames)} frames in [{a.t0}, {a.t1}] s (halves {H[0]['frames']} / {H[1]['frames']}), r < {a.rmax} R, {nb} bins")
print(f"  C_m(r<{a.rmax}R): coherent (cross of halves) {ke_coh:.4f}; first half alone, noise-biased {ke_self:.4f}; potential flow R sampled the same way {ke_pf:.4f}, unbinned {np.mean(pf_exact):.4f} (continuum {0.5*(1-a.rmax**-3):.4f})")
print(f"  Q = coherent / potential flow = {ke_coh/ke_pf:.3f}  -> (Q)^(1/6) = {(ke_coh/ke_pf)**(1/6):.3f} (dipole-strength radius if fluid stops at R)")
print("  radial profile of the bins (C_m contribution, coherent / potential):")
for i in range(len(redges) - 1):
    s_ = (rb == i) & ok
    print(f"    r {redges[i]/R:5.3f}-{redges[i+1]/R:5.3f} R: n/frame {nbar[rb==i].sum():7.1f}  coh {(0.5*m*nbar*cross)[s_].sum()/norm1:8.4f}  pf {(0.5*m*nbar*pf)[s_].sum()/norm1:8.4f}")
print("  projection on the potential flow, k = sum u.upf / sum upf^2 (raw field, all frames); R_eff/R = k^(1/3)")
for (lo, hi) in shells:
    print(f"    r/R {lo:.2f}-{hi:.2f}: " + "  ".join(f"{sn} k {proj[(lo, sn)][0]/proj[(lo, sn)][1]:5.2f}" for sn in sectors))
allp = sum(proj[(lo, sn)] for (lo, hi) in shells[:3] for sn in sectors)
print(f"    r < 2R, all sectors: k {allp[0]/allp[1]:.3f}  R_eff/R {np.cbrt(allp[0]/allp[1]):.3f}")
