#!/usr/bin/env python3
"""Shell counts around the towed ball of scenes/tests/stokes_tow.yaml (docs/forces.md, session 37).

Usage: tow_shells.py RUN_DIR...  (runs made with --set output.particles=true)
For the first, middle and last frame: the ball's centre from the scene's tow (x0 = 0.097 m, U = 0.01 m/s),
the number of particles (body and fluid) in 2.5 mm shells from r = 0.025 m (the body's layer, R - dx/2),
and how many lie within R + dx = 0.04 m in front of and behind the centre.
"""
import h5py, numpy as np, sys, csv
for run in sys.argv[1:]:
    f = h5py.File(run + '/particles.h5part', 'r')
    steps = sorted(f.keys(), key=lambda k: int(k.split('#')[1]))
    bodies = list(csv.DictReader(open(run + '/bodies.csv')))
    for st in [steps[0], steps[len(steps)//2], steps[-1]]:
        g = f[st]; t = g.attrs.get('TimeValue', None)
        x = np.stack([g['x'][:], g['y'][:], g['z'][:]], 1)
        # body centre: x0 + U t
        tt = float(np.array(t).ravel()[0])
        c = np.array([0.097 + 0.01 * tt, 0.1, 0.1])
        r = np.linalg.norm(x - c, axis=1)
        d = x - c
        front = d[:, 0] > 0
        h, e = np.histogram(r, bins=np.arange(0.025, 0.06, 0.0025))
        hf, _ = np.histogram(r[front], bins=e); hb, _ = np.histogram(r[~front], bins=e)
        print(run, 't=%.3f' % tt, 'min r %.4f' % r.min(), 'n<R+dx %d front %d back %d' % ((r < 0.04).sum(), (r[front] < 0.04).sum(), (r[~front] < 0.04).sum()))
        print('  shells', ' '.join('%d' % v for v in h))

