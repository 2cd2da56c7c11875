#!/usr/bin/env python3
"""C_m of the shaken ball with its held twin subtracted (session 15). usage: twinfit.py RUN... where each RUN_s is
accel_ball.yaml run with `output.step_forces: true` and RUN_h the same run of scenes/accel_ball_held.yaml (every
keyframe at x0). Fits F_shaken - F_held over 0.3-0.5 s as c + B v - C_m rho V a with the path's exact v and a at
each step's middle, and prints C_m with its standard error (and the fit without the twin)."""
import sys, numpy as np
R = 0.03; rho = 1000.0; V = 4 / 3 * np.pi * R**3; A = 1e-3; w = 2 * np.pi * 10
def load(d):
    rows = [l for l in open(d + "/forces.csv") if not l.startswith("#")]
    hdr = rows[0].strip().split(","); ix = {c: i for i, c in enumerate(hdr)}
    T = np.array([float(l.split(",")[ix["time"]]) for l in rows[1:]]); F = np.array([float(l.split(",")[ix["fluid_fx"]]) for l in rows[1:]])
    return T, F
for d in sys.argv[1:]:
    Ts, Fs = load(d + "_s"); Th, Fh = load(d + "_h")
    dt = np.diff(Ts, append=Ts[-1]); tm = Ts + dt / 2
    Fhi = np.interp(Ts, Th, Fh)
    m = (Ts >= 0.3) & (Ts < 0.5 - 1e-9)
    a = A * w * w * np.cos(w * (tm - 0.3)); v = A * w * np.sin(w * (tm - 0.3))
    M = np.stack([np.ones(m.sum()), v[m], -rho * V * a[m]], 1)
    c1 = np.linalg.lstsq(M, Fs[m] - Fhi[m], rcond=None)[0]; c0 = np.linalg.lstsq(M, Fs[m], rcond=None)[0]
    r = Fs[m] - Fhi[m] - M @ c1
    se = np.sqrt(np.var(r) * np.linalg.inv(M.T @ M)[2, 2] * m.sum() / (m.sum() - 3))
    print(f"{d}: {m.sum()} steps; C_m in phase, held twin subtracted {c1[2]:.3f} (se {se:.3f}, B {c1[1]:.2f}); without the twin {c0[2]:.3f}")
