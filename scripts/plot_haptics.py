#!/usr/bin/env python3
"""Plot the force sent to the haptic device against time from haptics.csv (sphaptics run with a
`haptics` section): one line per component and the magnitude, with the held body shaded.

    python3 scripts/plot_haptics.py out/haptic_stir/haptics.csv out/haptic_stir/haptics.png
"""
import csv
import sys


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    src, png = sys.argv[1], sys.argv[2]
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("error: matplotlib is needed (apt-get install python3-matplotlib)", file=sys.stderr)
        return 2
    t, fx, fy, fz, held = [], [], [], [], []
    with open(src, newline="") as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        for r in rows:
            t.append(float(r["time"]))
            fx.append(float(r["fx"]))
            fy.append(float(r["fy"]))
            fz.append(float(r["fz"]))
            held.append(int(r["body"]) >= 0)
    if not t:
        print(f"error: {src}: no rows", file=sys.stderr)
        return 2
    mag = [(a * a + b * b + c * c) ** 0.5 for a, b, c in zip(fx, fy, fz)]
    fig, ax = plt.subplots(figsize=(9, 4))
    # Shade the time a body is held.
    start = None
    for ti, h in zip(t + [t[-1]], held + [False]):
        if h and start is None:
            start = ti
        elif not h and start is not None:
            ax.axvspan(start, ti, color="0.92", lw=0)
            start = None
    ax.plot(t, fx, lw=0.8, label="fx")
    ax.plot(t, fy, lw=0.8, label="fy")
    ax.plot(t, fz, lw=0.8, label="fz")
    ax.plot(t, mag, lw=1.2, color="k", label="|f|")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("force sent to the device (N)")
    ax.set_title(src + "  (grey: a body is held)")
    ax.legend(loc="upper right", ncol=4)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
