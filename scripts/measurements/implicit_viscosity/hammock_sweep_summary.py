#!/usr/bin/env python3
"""Summary of hammock_sweep.sh: per areal density and viscosity, explicit and implicit: status, steps,
particles spilled below 0.15 m, the anchors' mean z force over 1.5-2 s against the weight of cloth and the
syrup still in it, the cloth's mean kinetic energy, wall time. Run in the sweep's output folder."""
import h5py, numpy as np, csv, json, os, sys
rows = []
for ad in ['0.5', '1', '2', '5']:
    for nu in ['0.001', '0.01', '0.1']:
        line = []
        for mode in ['explicit', 'implicit']:
            run = '%s_%s_%s' % (mode, ad, nu)
            try:
                j = json.load(open(run + '/run.json'))
            except Exception:
                line.append('%s: failed' % mode); continue
            if j.get('status') != 'completed' and j.get('status') != 'ok':
                pass
            if not os.path.exists(run + '/particles.h5part'):
                line.append('%s: %s (%s)' % (mode, j.get('status'), j.get('message', '')[:90])); continue
            f = h5py.File(run + '/particles.h5part', 'r')
            steps = sorted(f.keys(), key=lambda k: int(k.split('#')[1]))
            g = f[steps[-1]]; z = g['z'][:]; fl = g['type'][:] == 0
            spilled = int((z[fl] < 0.15).sum())
            rr = [r for r in csv.reader(l for l in open(run + '/cloth.csv') if not l.startswith('#'))][1:]
            a = np.array([[float(r[0]), float(r[-1]), float(r[2])] for r in rr])
            m = a[:, 0] >= 1.5 - 1e-9
            W = (float(ad) * 0.04 + (400 - spilled) * 1e-3) * 9.81
            line.append('%s: %s, steps %d, spilled %d, anchors %.3f N / W %.3f N (%+.1f %%), KE %.1e J, wall %.1f s' % (
                mode, j.get('status'), j['steps'], spilled, -a[m, 1].mean(), W, 100 * (-a[m, 1].mean() / W - 1), a[m, 2].mean(), j['wall_seconds']))
        print(ad, nu, ' | '.join(line))
