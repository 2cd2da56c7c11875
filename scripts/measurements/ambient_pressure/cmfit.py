# The shaken-ball check's fit (cli/force_checks.cpp, acceleratedBall) on a run's forces.csv over [t0, t1]
# (whole periods of the shaking): F_x = -M a - B v.
# Usage: cmfit.py forces.csv t0 t1 (prints C_m = M / (rho V) and B in N s/m; R = 3 cm, rho = 1000 kg/m^3)
#  - "fourier": the check since session 34: F, a and v projected on cos and sin of the fundamental (the
#    harmonic of the window where |a| is largest), each sample weighted by its step's length;
#  - "regression": the check until session 33: least squares on the per-step a and v, which the keyframed
#    path's own acceleration ripple biases low where the force does not follow it (docs/forces.md, session 34).
import sys, numpy as np
rows=[l.strip().split(',') for l in open(sys.argv[1]) if not l.startswith('#')]
hdr=rows[0]; rows=rows[1:]
col=lambda n: np.array([float(r[hdr.index(n)]) for r in rows])
t0, t1 = float(sys.argv[2]), float(sys.argv[3])
t=col('time'); v=col('vx'); F=col('fluid_fx')
V = 4/3*np.pi*0.03**3
a=(v[2:]-v[:-2])/(t[2:]-t[:-2]); tt=t[1:-1]; vv=v[1:-1]; FF=F[1:-1]; tn=t[2:]
m=(tt>=t0)&(tt<=t1)
(M,B),*_=np.linalg.lstsq(np.vstack([-a[m],-vv[m]]).T, FF[m], rcond=None)
print("regression: C_m %.4f B %.3f" % (M/(1000*V), B))
w=np.minimum(tn[m],t1)-tt[m]; ts=tt[m]-t0
def proj(y, o): return np.array([(w*y*np.cos(o*ts)).sum(), (w*y*np.sin(o*ts)).sum()])
om=max((2*np.pi*h/(t1-t0) for h in range(1,21)), key=lambda o: (proj(a[m],o)**2).sum())
A=proj(a[m],om); Vv=proj(vv[m],om); Fp=proj(FF[m],om)
(M,B),*_=np.linalg.lstsq(np.vstack([-A,-Vv]).T, Fp, rcond=None)
print("fourier (%.2f Hz): C_m %.4f B %.3f" % (om/(2*np.pi), M/(1000*V), B))
