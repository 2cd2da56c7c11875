#!/usr/bin/env python3
"""Layer pressures of the reference library's (SPlisHSPlasH) DFSPH hydrostatic tank.

Reads the legacy VTK particle files that SPlisHSPlasH writes (ParticleExporter_VTK: big-endian
binary, y up) with the attributes `density`, `p / rho^2` and `p_v / rho^2`, and prints per layer
(one spacing thick, the middle of the tank as tests/test_dfsph.cpp's hydrostaticTank) the mean
pressure against rho0 g d (d: the depth from the particles above), and the largest change of a
layer's mean pressure between consecutive exports (steps at 200 exports/s) and between exports
50 ms apart (frames).

The pressure, from SPlisHSPlasH's DFSPH (TimeStepDFSPH.cpp): its pressure acceleration is
a_i = -sum_j V_j (pr_i + pr_j) gradW_ij with pr = p rho0 / rho^2 ("p / rho^2" in its fields; kappa/rho
in B&K 2017), and at the end of a step it stores pr h^2 (density solve) and pr_v h (divergence
solve) for the next warm start, which is what an export after the step reads. So the pressure
that acted over the step (both solves, as sphaptics' dfsph_finish) is
    p = (pr_exported / h^2 + pr_v_exported / h) rho^2 / rho0.
Usage: peer_tank.py VTK_DIR DT T0 T1 [RHO0 G DX AREA]"""
import glob
import math
import os
import re
import struct
import sys


def read_vtk(path):
    """Positions (list of (x, y, z)) and scalar fields {name: list} of one SPlisHSPlasH VTK file."""
    data = open(path, "rb").read()
    pos = 0

    def line():
        nonlocal pos
        end = data.index(b"\n", pos)
        s = data[pos:end].decode()
        pos = end + 1
        return s

    for _ in range(4):
        line()
    head = line().split()  # POINTS n float
    n = int(head[1])
    size = 4 if head[2] == "float" else 8
    fmt = ">" + ("f" if size == 4 else "d")
    xyz = struct.unpack(">" + ("f" if size == 4 else "d") * 3 * n, data[pos:pos + 3 * n * size])
    pos += 3 * n * size + 1
    line()  # CELLS
    pos += 2 * n * 4 + 1
    line()  # CELL_TYPES
    pos += n * 4 + 1
    line()  # POINT_DATA
    line()  # SCALARS id
    line()  # LOOKUP_TABLE
    pos += n * 4 + 1
    nf = int(line().split()[2])  # FIELD FieldData k
    fields = {}
    for _ in range(nf):
        name, comps, count, typ = line().split()
        k = int(comps) * int(count)
        sz = 4 if typ == "float" else 8
        fields[name] = struct.unpack(">" + ("f" if sz == 4 else "d") * k, data[pos:pos + k * sz])
        pos += k * sz + 1
    pts = [(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]) for i in range(n)]
    return pts, fields


def main():
    vtk_dir, dt, t0, t1 = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
    rho0, g, dx, area = 1000.0, 9.81, 0.01, 0.2 * 0.06
    fps = 200.0
    files = glob.glob(os.path.join(vtk_dir, "ParticleData_*_*.vtk"))
    frames = sorted((int(re.search(r"_(\d+)\.vtk$", f).group(1)), f) for f in files)
    sums = {}      # layer -> [p sum, depth sum, count]
    prev_step = {}
    prev_frame = {}
    worst_step = worst_frame = 0.0
    used = 0
    for frame, path in frames:
        t = frame / fps  # export k is the first step end at or after k / fps
        if t < t0 - 1e-9 or t > t1 + 1e-9:
            continue
        pts, f = read_vtk(path)
        ys = sorted(p[1] for p in pts)
        n = len(ys)
        pr, prv, rho = f["p_/_rho^2"], f["p_v_/_rho^2"], f["density"]
        now = {}
        for i, (x, y, z) in enumerate(pts):
            if abs(x - 0.1) > 0.05 or abs(z - 0.03) > 0.01:
                continue
            k = int(math.floor(y / dx))
            # particles above (bisect on the sorted heights)
            lo, hi = 0, n
            while lo < hi:
                m = (lo + hi) // 2
                if ys[m] <= y:
                    lo = m + 1
                else:
                    hi = m
            depth = (n - lo) * dx ** 3 / area
            p = (pr[i] / dt ** 2 + prv[i] / dt) * rho[i] ** 2 / rho0
            L = now.setdefault(k, [0.0, 0.0, 0])
            L[0] += p
            L[1] += depth
            L[2] += 1
        for k, L in now.items():
            S = sums.setdefault(k, [0.0, 0.0, 0])
            S[0] += L[0]
            S[1] += L[1]
            S[2] += L[2]
            if L[1] / L[2] < 2 * dx:
                continue
            p = L[0] / L[2]
            if k in prev_step and frame - prev_step[k][0] == 1:
                worst_step = max(worst_step, abs(p - prev_step[k][1]))
            prev_step[k] = (frame, p)
            if frame % 10 == 0:
                if k in prev_frame:
                    worst_frame = max(worst_frame, abs(p - prev_frame[k]))
                prev_frame[k] = p
        used += 1
    worst = 0.0
    pbot = 0.0
    print("layer,depth_m,p_Pa,rho0_g_d_Pa,error_pct")
    for k in sorted(sums):
        p_sum, d_sum, c = sums[k]
        depth = d_sum / c
        if depth < 2 * dx:
            continue
        p, ref = p_sum / c, rho0 * g * depth
        worst = max(worst, abs(p / ref - 1))
        pbot = max(pbot, ref)
        print("%d,%.4f,%.1f,%.1f,%.2f" % (k, depth, p, ref, 100 * (p / ref - 1)))
    print("# %d exports in %.2f-%.2f s; worst layer %.2f %%; largest change of a layer's mean pressure "
          "between steps %.0f Pa (%.1f %% of rho0 g H = %.0f Pa), between frames 50 ms apart %.0f Pa (%.1f %%)"
          % (used, t0, t1, 100 * worst, worst_step, 100 * worst_step / pbot, pbot, worst_frame,
             100 * worst_frame / pbot))


if __name__ == "__main__":
    main()
