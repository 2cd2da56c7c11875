#!/usr/bin/env python3
"""The hammock's load at the end of a run (docs/dfsph.md, session 37).

Usage: hammock_anchor_means.py RUN_DIR...  (runs of scenes/tests/dfsph_hammock_syrup.yaml, with particles)
Prints how many fluid particles are below z = 0.15 m at the last frame (spilled from the hammock) and the
lowest fluid particle, then the mean and standard deviation of the anchors' z force (cloth.csv, one row per
frame; the weight of cloth and syrup is 0.6 kg x 9.81 = 5.89 N) and the cloth's mean kinetic energy over
three windows.
"""
import h5py, numpy as np, sys, csv
for run in sys.argv[1:]:
    f = h5py.File(run + '/particles.h5part', 'r')
    steps = sorted(f.keys(), key=lambda k: int(k.split('#')[1]))
    rows = [r for r in csv.reader(l for l in open(run + '/cloth.csv') if not l.startswith('#'))][1:]
    fz = np.array([[float(r[0]), float(r[-1]), float(r[2])] for r in rows])
    for st in steps[-1:]:
        g = f[st]; z = g['z'][:]; ty = g['type'][:]; fl = ty == 0
        print(run, 'fluid', fl.sum(), 'below 0.15 m (spilled to floor region):', (z[fl] < 0.15).sum(), 'min z %.3f' % z[fl].min())
    for a, b in [(1.0, 1.5), (1.5, 2.0), (1.7, 2.0)]:
        m = (fz[:, 0] > a - 1e-9) & (fz[:, 0] <= b + 1e-9)
        print('  anchor fz mean %.1f-%.1f s: %.3f N (std %.3f), cloth KE %.2e J' % (a, b, fz[m, 1].mean(), fz[m, 1].std(), fz[m, 2].mean()))
