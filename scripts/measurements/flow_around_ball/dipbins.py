#!/usr/bin/env python3
"""Shaken ball minus its held twin (session 15): the velocity's and the pressure's dipole strength in radial bins.
usage: dipbins.py SHAKEN_RUN HELD_RUN [--rmax 3]
Per frame (both runs' frames at the same times, particles by id; positions and ball centre of the shaken run):
  du = u_shaken - u_held, dp = p_shaken - p_held (the held run's tank noise and hydrostatics drop out).
  Per bin of r: du = u0 + k_t g(x), g = the potential flow of a sphere of radius R per unit speed along x;
               dp = c + q_t rho0 R^3 cos(theta) / (2 r^2)  (the accelerating sphere's surface pressure law).
  Then over 0.3-0.5 s: k_t = ku v(t) + ..., q_t = kp a(t) + ... (in phase; |.|: with the lag term).
Potential flow: ku = kp = 1 in every bin (unbounded; the tank adds a few per cent)."""
import sys, json, argparse, numpy as np, h5py
from common import ball_track, shaken_path
ap = argparse.ArgumentParser(); ap.add_argument("run"); ap.add_argument("held"); ap.add_argument("--rmax", type=float, default=3.0)
a = ap.parse_args()
R = 0.03; rho0 = 1000.0; A = 1e-3; w = 2 * np.pi * 10
dx = json.load(open(a.run + "/run.json"))["scene"]["fluid"]["particle_spacing"]
vf, af = shaken_path(A, 10.0)
track = ball_track(a.run)
fs, fh = h5py.File(a.run + "/particles.h5part", "r"), h5py.File(a.held + "/particles.h5part", "r")
def frames(f): return {round(float(f[k].attrs["TimeValue"]), 6): k for k in f if k.startswith("Step#")}
Fs, Fh = frames(fs), frames(fh)
edges = np.unique(np.array([R, R + 1.5 * dx, 1.5 * R, 2 * R, 2.5 * R, a.rmax * R]))
def load(g):
    sel = g["type"][()] == 0; idx = g["id"][()][sel]; o = np.argsort(idx)
    X = np.stack([g["x"][()], g["y"][()], g["z"][()]], 1)[sel][o].astype(float)
    U = np.stack([g["velocity_0"][()], g["velocity_1"][()], g["velocity_2"][()]], 1)[sel][o].astype(float)
    return idx[o], X, U, g["pressure"][()][sel][o].astype(float)
times = sorted(t for t in Fs if 0.3 < t <= 0.5 + 1e-9 and t in Fh)
Q, K, U0, SR, NS = [], [], [], [], []
for t in times:
    i1, X, U, P = load(fs[Fs[t]]); i2, _, Uh, Ph = load(fh[Fh[t]])
    assert np.array_equal(i1, i2)
    c = track[t][0]; s = X - c; r = np.linalg.norm(s, axis=1); n = s / r[:, None]; cs = n[:, 0]
    du = U - Uh; dp = P - Ph
    qb, kb, u0b = [], [], []
    for b in range(len(edges) - 1):
        m = (r >= edges[b]) & (r < edges[b + 1])
        gg = (R**3 / (2 * r[m]**3))[:, None] * (3 * cs[m][:, None] * n[m] - np.array([1.0, 0, 0]))
        Mv = np.zeros((3 * m.sum(), 4)); Mv[0::3, 0] = 1; Mv[1::3, 1] = 1; Mv[2::3, 2] = 1; Mv[:, 3] = gg.reshape(-1)
        cvb = np.linalg.lstsq(Mv, du[m].reshape(-1), rcond=None)[0]
        kb.append(cvb[3]); u0b.append(cvb[0])
        if b == 0:  # the layer the body touches: x-velocity beyond the dipole (k_t g) by sector, and the sectors' sizes
            res = du[m, 0] - cvb[3] * gg[:, 0]; cm = cs[m]
            secs = [(np.abs(cm) > 0.7), (np.abs(cm) <= 0.7) & (np.abs(cm) > 0.3), (np.abs(cm) <= 0.3)]
            SR.append([res[q].mean() for q in secs] + [res[q].sum() / m.sum() for q in secs]); NS.append([q.sum() for q in secs])
        Mp = np.stack([np.ones(m.sum()), rho0 * R**3 * cs[m] / (2 * r[m]**2)], 1)
        qb.append(np.linalg.lstsq(Mp, dp[m], rcond=None)[0][1])
    Q.append(qb); K.append(kb); U0.append(u0b)
Q, K, T, U0 = np.array(Q), np.array(K), np.array(times), np.array(U0)
# the pressure of frame t is the step's that ended at t (computed at its start): take a at t - dt/2
dt = np.median(np.diff(T))
aa = np.array([af(t - dt / 2) for t in T]); va = np.array([vf(t - dt / 2) for t in T])
vv = np.array([vf(t) for t in T]); av = np.array([af(t) for t in T])
print(f"{a.run} - {a.held}: {len(T)} frames, dx {dx}, frame dt {dt*1e3:.2f} ms")
print("  bin (r/R)        ku in phase (|ku|)    kp in phase (|kp|)    uniform u_x / v in phase")
for b in range(len(edges) - 1):
    Mu = np.stack([np.ones(len(T)), vv, av / w], 1); cu = np.linalg.lstsq(Mu, K[:, b], rcond=None)[0]
    Mp = np.stack([np.ones(len(T)), aa, va * w], 1); cp = np.linalg.lstsq(Mp, Q[:, b], rcond=None)[0]
    c0 = np.linalg.lstsq(Mu, U0[:, b], rcond=None)[0]
    print(f"  {edges[b]/R:.2f}-{edges[b+1]/R:.2f}     {cu[1]:+.3f} ({np.hypot(cu[1], cu[2]):.3f})        {cp[1]:+.3f} ({np.hypot(cp[1], cp[2]):.3f})        {c0[1]:+.4f}")
SR = np.array(SR); NS = np.array(NS).mean(0)
Mu = np.stack([np.ones(len(T)), vv, av / w], 1)
cf = [np.linalg.lstsq(Mu, SR[:, q], rcond=None)[0][1] for q in range(6)]
print(f"  first bin, u_x beyond the dipole / v by sector (|cos theta| > 0.7 front/back, 0.3-0.7, < 0.3 sides): "
      f"mean {cf[0]:+.4f} / {cf[1]:+.4f} / {cf[2]:+.4f}; share of the bin's mean {cf[3]:+.4f} / {cf[4]:+.4f} / {cf[5]:+.4f}; particles {NS[0]:.0f} / {NS[1]:.0f} / {NS[2]:.0f}")
