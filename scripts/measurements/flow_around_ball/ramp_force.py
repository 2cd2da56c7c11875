#!/usr/bin/env python3
"""Force-based C_m from the tow's acceleration ramp (session 14 helper).
usage: ramp_force.py RUN_DIR [--lag STEPS]
Fits forces.csv F_x(t) = c + B v(t) - C_m rho V a(t - lag) over 0.25-0.45 s, v the logged (analytic path)
velocity, a its central difference; also the impulse form: mean F_x over 0.36-0.45 s minus over 0.2-0.3 s
(the steady part) and the ramp impulse int (F - F_rest - F_steady v/U) dt = -C_m rho V U."""
import sys, numpy as np, argparse
ap = argparse.ArgumentParser(); ap.add_argument("d"); ap.add_argument("--lag", type=float, default=0.0, help="s")
ap.add_argument("--rest", default="", help="subtract this held-ball run's F_x (interpolated to the same times)")
ap.add_argument("--R", type=float, default=0.03)
a = ap.parse_args()
rho = 1000.0; V = 4 / 3 * np.pi * a.R**3
rows = [l for l in open(a.d + "/forces.csv") if not l.startswith("#")]
hdr = rows[0].strip().split(",")
D = np.array([[float(x) for x in l.strip().split(",")[0:1] + l.strip().split(",")[2:]] for l in rows[1:]])
cols = [hdr[0]] + hdr[2:]
ix = {c: i for i, c in enumerate(cols)}
t = D[:, ix["time"]]; v = D[:, ix["vx"]]; F = D[:, ix["fluid_fx"]]
U = v.max()
if a.rest:
    rr = [l for l in open(a.rest + "/forces.csv") if not l.startswith("#")]
    Dr = np.array([[float(x) for x in l.strip().split(",")[0:1] + l.strip().split(",")[2:]] for l in rr[1:]])
    F = F - np.interp(t, Dr[:, ix["time"]], Dr[:, ix["fluid_fx"]])
acc = np.gradient(v, t)
al = np.interp(t - a.lag, t, acc)
w = (t >= 0.25) & (t <= 0.45)
A = np.stack([np.ones(w.sum()), v[w], -rho * V * al[w]], 1)
coef, *_ = np.linalg.lstsq(A, F[w], rcond=None)
res = F[w] - A @ coef
rest = (t >= 0.2) & (t < 0.3); tow = (t >= 0.37) & (t <= 0.55)
Fr = F[rest].mean(); Ft = F[tow].mean()
# impulse over the ramp window 0.3-0.36 with the steady part removed in proportion to v
ramp = (t >= 0.295) & (t <= 0.37)
dt = np.gradient(t)
imp = ((F[ramp] - Fr - (Ft - Fr) * v[ramp] / U) * dt[ramp]).sum()
print(f"{a.d}: steps {len(t)} (dt~{np.median(np.diff(t))*1e3:.2f} ms)  U={U:.4f}  fit lag {a.lag*1e3:.1f} ms: C_m {coef[2]:.3f}  B {-coef[1]:.3f} N s/m  c {coef[0]:.4f} N  resid rms {res.std():.4f} N")
print(f"   F rest {Fr:.4f} N (sd {F[rest].std():.4f})  F towed {Ft:.4f} N (sd {F[tow].std():.4f})  steady drag {Fr-Ft:.4f} N; ramp impulse C_m {-imp/(rho*V*U):.3f}")
