#!/usr/bin/env python3
"""C_m of a shaken-ball run at frequency F (make_shake.py): forces.csv F_x fitted over the shaking as
c + B v(t) - C_m rho V a(t) with the exact path (in phase), and with the check's estimator (a from central differences
of the logged v).  usage: freq.py RUN F_HZ A_M"""
import sys, numpy as np
d, f, A = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
R = 0.03; rho = 1000.0; V = 4 / 3 * np.pi * R**3; w = 2 * np.pi * f
rows = [l for l in open(d + "/forces.csv") if not l.startswith("#")]
hdr = rows[0].strip().split(","); ix = {c: i for i, c in enumerate(hdr)}
T = np.array([float(l.split(",")[ix["time"]]) for l in rows[1:]]); F = np.array([float(l.split(",")[ix["fluid_fx"]]) for l in rows[1:]])
VX = np.array([float(l.split(",")[ix["vx"]]) for l in rows[1:]])
t1 = T.max()
dt = np.diff(T, append=T[-1]); tm = T + dt / 2  # the step's middle
v = np.where(tm >= 0.3, A * w * np.sin(w * (tm - 0.3)), 0); a = np.where(tm >= 0.3, A * w * w * np.cos(w * (tm - 0.3)), 0)
m = (T >= 0.3) & (T < t1 - 1e-9)
M = np.stack([np.ones(m.sum()), v[m], -rho * V * a[m]], 1); cf, *_ = np.linalg.lstsq(M, F[m], rcond=None)
ac = np.zeros_like(T); ac[1:-1] = (VX[2:] - VX[:-2]) / (T[2:] - T[:-2]); mk = m.copy(); mk[0] = mk[-1] = False
Mk = np.stack([ac[mk], VX[mk]], 1); ck, *_ = np.linalg.lstsq(Mk, F[mk], rcond=None)
print(f"{d}: f {f} Hz, A {A*1e3:.3f} mm, {m.sum()} steps (median dt {np.median(np.diff(T[m]))*1e3:.2f} ms): "
      f"C_m in phase {cf[2]:.3f} (B {cf[1]:.2f} N s/m, amplitude {np.hypot(cf[2], cf[1] / (rho * V * w)):.3f}); check's estimator {-ck[0] / (rho * V):.3f}")
