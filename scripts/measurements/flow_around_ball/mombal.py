#!/usr/bin/env python3
"""Per-step x-momentum balance of the fluid near the shaken ball (session 15).

usage: mombal.py RUN_DIR [--t0 0.3 --t1 0.5] [--radii 1.25,1.5,2]
RUN_DIR: accel_ball.yaml run with output.particles and output.step_forces, ideally one frame per step.

For each pair of consecutive frames k -> k+1 (one step when the frame rate matches the step):
  positions x_k (frame k), velocities u_k, u_{k+1}, pressures and densities of frame k+1 (the step's: they
  are computed at x_k, at the step's start, and written with the step's end state).
  For a sphere S(r_s) around the ball's centre c(t_k) (fluid particles with |x_i - c| < r_s, by id):
   (a) Mdot = sum_{i in S} m (u_{i,k+1} - u_{i,k}) / dt          (the inside fluid's momentum change, material)
   (c) T    = sum over fluid pairs (i in S, j outside, |x_ij| < H) of the SPH pressure force on i from j,
              f_ij = -(p_i / delta_i^2 + p_j / delta_j^2) gradW_ij    (delta = rho / m; pressure.cl / dfsph.cl)
   (b) Fb   = -F_body (forces.csv at t_k): the body's terms on the fluid (all inside once r_s > R + H)
   residual = Mdot - T - Fb (zero when the balance closes: the pair formula is the code's and every
              fluid particle the body touches is inside).
  T_pot: the same pair sum with the potential-flow pressure of an accelerating sphere in place of p:
         p_pot(x) = rho0 a (x - c)_x R^3 / (2 r^3)  (unbounded; a = the path's acceleration at t_k);
         continuum value across any sphere: -(1/2) rho V a.
Each series is fitted over [t0, t1] as Q(t) = c0 + Ca rho V a(t) + Cv rho V v(t) (exact path v, a at t_k + dt/2);
printed: Ca (in phase with a; the body's C_m is -Ca of -Fb... i.e. Fb's Ca), and |C| = sqrt(Ca^2 + (Cv/w)^2).
"""
import sys, json, argparse, numpy as np, h5py
from scipy.spatial import cKDTree
from common import ball_track, shaken_path

ap = argparse.ArgumentParser()
ap.add_argument("run")
ap.add_argument("--t0", type=float, default=0.3)
ap.add_argument("--t1", type=float, default=0.5)
ap.add_argument("--radii", default="1.25,1.5,1.75,2")
ap.add_argument("--dump", default="")
ap.add_argument("--ref", default="", help="held-ball twin run: its series (same frames) are subtracted before the fits")
a = ap.parse_args()
d = a.run
R = 0.03; rho0 = 1000.0; V = 4 / 3 * np.pi * R**3; A = 1e-3; w = 2 * np.pi * 10
spec = json.load(open(d + "/run.json"))["scene"]
dx = spec["fluid"]["particle_spacing"]; H = 2 * dx; m = rho0 * dx**3
radii = [R + float(s[1:]) * dx if s.startswith("d") else float(s) * R for s in a.radii.split(",")]
vf, af = shaken_path(A, 10.0)
def series(d, track_from=None):
    track = ball_track(track_from or d)
    # step forces: time -> fx
    fb = {}
    rows = [r for r in open(d + "/forces.csv") if not r.startswith("#")]
    hdr = rows[0].strip().split(",")
    for r in rows[1:]:
        s = r.strip().split(",")
        fb[round(float(s[0]), 7)] = float(s[hdr.index("fluid_fx")])
    ftimes = np.array(sorted(fb))


    def grad_factor(r):
        q = r / H; s = 8 / np.pi / H**3; t = np.maximum(1 - q, 0); qs = np.maximum(q, 0.25)
        return s * np.where(q <= 0.5, 18 * q - 12, -6 * t * t / qs) / H**2


    f = h5py.File(d + "/particles.h5part", "r")
    steps = sorted((float(f[k].attrs["TimeValue"]), k) for k in f if k.startswith("Step#"))


    def load(k):
        g = f[k]
        sel = g["type"][()] == 0
        idx = g["id"][()][sel]; o = np.argsort(idx)
        X = np.stack([g["x"][()], g["y"][()], g["z"][()]], 1)[sel][o].astype(float)
        U = np.stack([g["velocity_0"][()], g["velocity_1"][()], g["velocity_2"][()]], 1)[sel][o].astype(float)
        return idx[o], X, U, g["pressure"][()][sel][o].astype(float), g["density"][()][sel][o].astype(float)


    out = []
    prev = None
    for t, k in steps:
        if t < a.t0 - 0.006 or t > a.t1 + 1e-9:
            prev = None
            continue
        cur = (t, load(k))
        if prev is None:
            prev = cur; continue
        (tk, (id0, X0, U0, _, _)), (tk1, (id1, X1, U1, P1, RHO1)) = prev, cur
        prev = cur
        if tk < a.t0 - 1e-9 or len(id0) != len(id1) or not np.array_equal(id0, id1):
            continue
        dt = tk1 - tk
        nsteps = int(np.sum((ftimes >= tk - 1e-7) & (ftimes < tk1 - 1e-7)))
        Fbody = np.mean([fb[tt] for tt in ftimes[(ftimes >= tk - 1e-7) & (ftimes < tk1 - 1e-7)]])
        c = track[round(tk, 6)][0]
        s = X0 - c; r = np.linalg.norm(s, axis=1)
        reg = np.where(r < max(radii) + 1.5 * H)[0]
        tree = cKDTree(X0[reg]); pr = tree.query_pairs(H, output_type="ndarray")
        I = reg[pr[:, 0]]; J = reg[pr[:, 1]]
        dvec = X0[I] - X0[J]; rr = np.linalg.norm(dvec, axis=1); F = grad_factor(rr)
        di = RHO1[I] / m; dj = RHO1[J] / m
        fx = -(P1[I] / di**2 + P1[J] / dj**2) * F * dvec[:, 0]  # force on I from J (x); on J: -fx
        acc = af(tk + dt / 2)
        ppot = rho0 * acc * s[:, 0] * R**3 / (2 * np.maximum(r, 0.5 * R)**3)
        ph = rho0 * 9.81 * (0.18 - X0[:, 2])  # hydrostatic pressure at the particles (the arrangement's effect)
        fxh = -(ph[I] / di**2 + ph[J] / dj**2) * F * dvec[:, 0]
        fxp = -(ppot[I] / di**2 + ppot[J] / dj**2) * F * dvec[:, 0]
        row = [tk, dt, nsteps, -Fbody]
        for rs in radii:
            inside = r < rs
            ii, jj = inside[I], inside[J]
            cross_ij = ii & ~jj; cross_ji = jj & ~ii
            T = fx[cross_ij].sum() - fx[cross_ji].sum()
            Tp = fxp[cross_ij].sum() - fxp[cross_ji].sum()
            Md = m * (U1[inside, 0] - U0[inside, 0]).sum() / dt
            Th = fxh[cross_ij].sum() - fxh[cross_ji].sum()
            gx = R**3 * (3 * (s[inside, 0] / r[inside])**2 - 1) / (2 * r[inside]**3)  # dipole u_x per unit U
            row += [Md, T, Tp, m * gx.sum() * acc, Th]
        out.append(row)

    return np.array(out)


out = series(d)
if a.ref:
    ref = series(a.ref, track_from=d)  # the shaken ball's control volumes in the held run too
    n = min(len(out), len(ref)); assert np.allclose(out[:n, 0], ref[:n, 0])
    out = out[:n].copy(); keep = out.copy(); out[:, 3:] -= ref[:n, 3:]; out[:, 6::5] = keep[:, 6::5]; out[:, 7::5] = keep[:, 7::5]  # T_pot: the shaken run's

if a.dump: np.save(a.dump, out)
T = out[:, 0] + out[:, 1] / 2
M = np.stack([np.ones(len(T)), rho0 * V * np.array([af(t) for t in T]), rho0 * V * np.array([vf(t) for t in T])], 1)


def fit(y):
    cf, *_ = np.linalg.lstsq(M, y, rcond=None)
    res = y - M @ cf
    cov = np.linalg.inv(M.T @ M) * np.var(res) * len(y) / max(len(y) - 3, 1)
    return cf[1], np.hypot(cf[1], cf[2] / w), np.sqrt(cov[1, 1])


print(f"{d}: {len(out)} intervals, steps per interval {np.unique(out[:, 2])}, dx {dx}")
ca, amp, sd = fit(out[:, 3])
print(f"  body on fluid (-F_body):            Ca {ca:+.3f}  |C| {amp:.3f}  se {sd:.3f}")
for n, rs in enumerate(radii):
    Md, Tt, Tp, Mp, Th = (out[:, 4 + 5 * n + q] for q in range(5))
    line = f"  r_s = {rs / R:.2f} R: "
    for name, y in (("Mdot", Md), ("T", Tt), ("resid Mdot-T-Fb", Md - Tt - out[:, 3]), ("T_pot(same particles)", Tp), ("Mdot_pot(dipole, same particles)", Mp), ("T_hydro(rho g depth, actual particles)", Th)):
        ca, amp, sd = fit(y)
        line += f"{name} {ca:+.3f} (|{amp:.3f}|, se {sd:.3f})  "
    print(line)
