#!/usr/bin/python3
"""Plot the accuracy benchmark: dam-break front error against wall time.

Usage: /usr/bin/python3 scripts/plot_bench.py bench/accuracy.csv bench/accuracy.png
Needs Debian's python3-matplotlib (installed by scripts/install_deps.sh).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(src, dst):
    rows = [r for r in csv.DictReader(line for line in open(src) if not line.startswith("#"))]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    markers = {"linear": "o", "tait": "s", "-": "^"}
    colours = {("wcsph", "0.4"): "tab:blue", ("wcsph", "0.2"): "tab:orange",
               ("dfsph", "0.4"): "tab:green", ("dfsph", "0.2"): "tab:red"}
    for solver in ("wcsph", "dfsph"):
      for eos in ("linear", "tait", "-"):
        for cfl in ("0.4", "0.2"):
            pts = [r for r in rows if r.get("solver", "wcsph") == solver and r["eos"] == eos
                   and abs(float(r["cfl"]) - float(cfl)) < 1e-6]
            if not pts:
                continue
            pts.sort(key=lambda r: float(r["wall_s"]))
            label = f"WCSPH, {eos} EOS, Courant {cfl}" if solver == "wcsph" else f"DFSPH, Courant {cfl}"
            ax.plot([float(r["wall_s"]) for r in pts], [100 * float(r["mean_rel_error"]) for r in pts],
                    marker=markers[eos], color=colours[(solver, cfl)], label=label)
            for r in pts:
                ax.annotate(f"{int(r['particles']) // 1000}k", (float(r["wall_s"]), 100 * float(r["mean_rel_error"])),
                            textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_xscale("log")
    ax.set_xlabel("wall time of the run [s]")
    ax.set_ylabel("mean |Z_sim - Z_exp| / Z_exp [%]")
    ax.set_title("Dam-break front vs Martin & Moyce (1952): error against cost")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(dst, dpi=120)
    print(f"wrote {dst}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
