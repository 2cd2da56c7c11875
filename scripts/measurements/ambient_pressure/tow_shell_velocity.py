#!/usr/bin/env python3
"""Mean x velocity of the fluid, over U, in 5 mm shells from R around the towed ball of
scenes/tests/stokes_tow.yaml at the last frame, and the fluid's mean pressure (docs/forces.md, session 37).

Usage: tow_shell_velocity.py RUN_DIR...  (runs made with --set output.particles=true)
"""
import h5py, numpy as np, sys
for run in sys.argv[1:]:
    f = h5py.File(run + '/particles.h5part', 'r')
    steps = sorted(f.keys(), key=lambda k: int(k.split('#')[1]))
    g = f[steps[-1]]; tt = float(np.array(g.attrs['TimeValue']).ravel()[0])
    x = np.stack([g['x'][:], g['y'][:], g['z'][:]], 1); vx = g['velocity_0'][:]; ty = g['type'][:]; p = g['pressure'][:]
    fl = ty == 0
    c = np.array([0.097 + 0.01 * tt, 0.1, 0.1]); r = np.linalg.norm(x - c, axis=1)
    e = np.arange(0.03, 0.08, 0.005)
    out = []
    for a, b in zip(e[:-1], e[1:]):
        m = fl & (r >= a) & (r < b)
        out.append('%.2f' % (vx[m].mean() / 0.01))
    side = fl & (np.abs(x[:,0]-c[0]) < 0.01)
    print(run, 't=%.2f' % tt, 'types', np.unique(ty), 'vx/U by shell from R:', ' '.join(out), ' mean p %.1f' % p[fl].mean())
