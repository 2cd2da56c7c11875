# The shaken-ball check's fit (cli/force_checks.cpp, acceleratedBall) on a run's forces.csv: F_x = -M a - B v over [t0, t1].
# Usage: cmfit.py forces.csv t0 t1 (prints C_m = M / (rho V) and B in N s/m; R = 3 cm, rho = 1000 kg/m^3).
import sys, numpy as np
rows=[l.strip().split(',') for l in open(sys.argv[1]) if not l.startswith('#')]
hdr=rows[0]; rows=rows[1:]
col=lambda n: np.array([float(r[hdr.index(n)]) for r in rows])
t0, t1 = float(sys.argv[2]), float(sys.argv[3])
t=col('time'); v=col('vx'); F=col('fluid_fx')
V = 4/3*np.pi*0.03**3
a=(v[2:]-v[:-2])/(t[2:]-t[:-2]); tt=t[1:-1]; vv=v[1:-1]; FF=F[1:-1]
m=(tt>=t0)&(tt<=t1)
(M,B),*_=np.linalg.lstsq(np.vstack([-a[m],-vv[m]]).T, FF[m], rcond=None)
print("C_m %.3f B %.3f" % (M/(1000*V), B))
