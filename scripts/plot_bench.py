#!/usr/bin/python3
"""Plot the accuracy benchmark: dam-break front error against wall time.

Usage: /usr/bin/python3 scripts/plot_bench.py bench/accuracy.csv bench/accuracy.png
Needs Debian's python3-matplotlib (installed by scripts/install_deps.sh).

Every row of the CSV is drawn: one series per (solver, equation of state, Courant number), in the
order the rows first name them, its points joined in order of wall time and labelled with their
particle count. Prints one line per series ("series: LABEL: N runs") and a total; exits 1 with a
message when the file holds no run to plot, so an empty figure is never written as a result.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402


def label_of(solver, eos, cfl):
    """Legend text of one series: the solver and wall model, WCSPH's equation of state, the Courant number."""
    if solver == "wcsph":
        name = f"WCSPH, {eos} EOS"
    elif solver == "dfsph":
        name = "DFSPH"
    elif solver.startswith("dfsph-"):
        name = f"DFSPH, {solver[len('dfsph-'):]} walls"
    else:
        name = solver
    return f"{name}, Courant {cfl:g}"


def main(src, dst):
    rows = [r for r in csv.DictReader(line for line in open(src) if not line.startswith("#"))]
    series = {}  # (solver, eos, cfl) -> rows, in the order of first appearance
    for r in rows:
        key = (r.get("solver", "wcsph"), r["eos"], round(float(r["cfl"]), 6))
        series.setdefault(key, []).append(r)
    if not series:
        sys.exit(f"plot_bench.py: {src} holds no accuracy run to plot")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    markers = {"linear": "o", "tait": "s", "-": "^"}
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for n, ((solver, eos, cfl), pts) in enumerate(series.items()):
        pts.sort(key=lambda r: float(r["wall_s"]))
        label = label_of(solver, eos, cfl)
        ax.plot([float(r["wall_s"]) for r in pts], [100 * float(r["mean_rel_error"]) for r in pts],
                marker=markers.get(eos, "D"), color=colours[n % len(colours)], label=label)
        for r in pts:
            ax.annotate(f"{int(r['particles']) // 1000}k", (float(r["wall_s"]), 100 * float(r["mean_rel_error"])),
                        textcoords="offset points", xytext=(4, 4), fontsize=8)
        print(f"series: {label}: {len(pts)} runs")
    ax.set_xscale("log")
    # plain numbers on the time axis (the default's 2.85 x 10^1 labels run together over a narrow range)
    ax.xaxis.set_major_formatter(matplotlib.ticker.LogFormatter())
    ax.xaxis.set_minor_formatter(matplotlib.ticker.LogFormatter(labelOnlyBase=False, minor_thresholds=(2, 0.5)))
    ax.set_xlabel("wall time of the run [s]")
    ax.set_ylabel("mean |Z_sim - Z_exp| / Z_exp [%]")
    ax.set_title("Dam-break front vs Martin & Moyce (1952): error against cost")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(dst, dpi=120)
    print(f"plotted {len(rows)} runs in {len(series)} series")
    print(f"wrote {dst}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
