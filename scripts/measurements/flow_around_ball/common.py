"""Shared by the analysis scripts of this folder: the ball's track from a run's bodies.csv, and the
shaken ball's prescribed path (scenes/tests/accel_ball.yaml as of session 14: x = x0 + A (1 - cos w (t - 0.3 s)), A = 1 mm;
since session 34 the scene shakes A = 3 mm from t0 = 0.05 s after a settle: pass A and t0)."""
import csv
import numpy as np


def ball_track(run_dir):
    """{time (rounded to 1 us): (centre of mass as a numpy array, vx)} of the run's first body."""
    track = {}
    rows = [r for r in open(run_dir + "/bodies.csv") if not r.startswith("#")]
    for r in csv.DictReader(rows):
        track[round(float(r["time"]), 6)] = (np.array([float(r["com_x"]), float(r["com_y"]), float(r["com_z"])]), float(r["vx"]))
    return track


def shaken_path(A=1e-3, f=10.0, t0=0.3):
    """The shaken ball's velocity v(t) and acceleration a(t) along x."""
    w = 2 * np.pi * f
    v = lambda t: A * w * np.sin(w * (t - t0)) if t >= t0 else 0.0
    a = lambda t: A * w * w * np.cos(w * (t - t0)) if t >= t0 else 0.0
    return v, a
