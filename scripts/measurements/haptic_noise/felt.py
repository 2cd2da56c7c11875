#!/usr/bin/python3
"""What a haptic user feels: statistics of the force sent to the device (haptics.csv).

usage: felt.py HAPTICS_CSV --from T0 --to T1 [--axis x|y|z] [--ref F]

Over the window it prints, for the felt force along the axis (N): the mean; the RMS fluctuation
about the window's least-squares line (the slow physical change removed); the part of that
fluctuation in 5-25 Hz (a tremor band the 25 Hz servo filter passes) and above 25 Hz (one-sided
DFT band power, Parseval, Hann window not used: the detrended signal is periodised as is); the
largest change per servo tick; and, with --ref, each as a fraction of F.
"""
import argparse
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("csv")
ap.add_argument("--from", dest="t0", type=float, required=True)
ap.add_argument("--to", dest="t1", type=float, required=True)
ap.add_argument("--axis", default="z", choices="xyz")
ap.add_argument("--ref", type=float, default=None)
ap.add_argument("--label", default="")
a = ap.parse_args()

rows = [l for l in open(a.csv) if not l.startswith("#")]
hdr = rows[0].strip().split(",")
d = np.array([[float(v) for v in l.split(",")] for l in rows[1:] if l.strip()])
t = d[:, hdr.index("time")]
f = d[:, hdr.index("f" + a.axis)]
m = (t >= a.t0) & (t <= a.t1)
t, f = t[m], f[m]
dt = np.median(np.diff(t))
c = np.polyfit(t, f, 1)
r = f - np.polyval(c, t)
n = len(r)
F = np.fft.rfft(r)
freq = np.fft.rfftfreq(n, dt)
p = np.abs(F) ** 2 / n**2
p[1:] *= 2
if n % 2 == 0:
    p[-1] /= 2
band = lambda lo, hi: float(np.sqrt(p[(freq >= lo) & (freq < hi)].sum()))
out = {
    "mean": float(f.mean()),
    "rms": float(np.sqrt((r**2).mean())),
    "5-25Hz": band(5, 25),
    ">25Hz": band(25, 1e9),
    "max_tick": float(np.abs(np.diff(f)).max()),
}
ref = a.ref if a.ref else None
s = " ".join(f"{k} {v:.4f} N" + (f" ({100*v/ref:.1f} %)" if ref else "") for k, v in out.items())
print(f"{a.label} {a.axis} [{a.t0},{a.t1}] s, {n} ticks: {s}")
