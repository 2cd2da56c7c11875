#!/usr/bin/env python3
"""Write scripts/measurements/flow_around_ball/scenes/tow_ke_u*.yaml (python3 make_tow.py U FILE): accel_ball.yaml's tank, the ball held to t0 = 0.3 s, its speed
raised by a smoothstep over T = 0.05 s to U along x, then towed at U to the end (0.55 s).
U = 0 gives the same scene with the ball held still (the lattice-noise reference)."""
import sys
U = float(sys.argv[1]); out = sys.argv[2]
x0, y0, z0 = 0.095, 0.105, 0.08
t0, T, t_end, dt = 0.300, 0.050, 0.600, 0.005
def x(t):
    if t <= t0: return x0
    tau = (t - t0) / T
    if tau <= 1: return x0 + U * T * (tau**3 - tau**4 / 2)
    return x0 + U * T / 2 + U * (t - t0 - T)
keys = []
n = int(round((t_end - t0) / dt))
for i in range(n + 1):
    t = t0 + i * dt
    keys.append(f"        - {{time: {t:.3f}, position: [{x(t):.8f}, {y0}, {z0}]}}")
with open(out, "w") as f:
    f.write(f"""# Session 14 (helper): fluid kinetic energy around a towed ball. accel_ball.yaml's tank (0.21 m,
# inviscid, gravity on); the ball (R = 3 cm) held at rest to 0.3 s while the fluid settles, then its
# speed raised by a smoothstep over 0.05 s to U = {U} m/s along x and held at U to 0.55 s.
# Potential flow: fluid KE = 1/2 C_m rho V U^2. Written by scripts/measurements/flow_around_ball/make_tow.py.
simulation:
  duration: 0.55
  frame_rate: 100
  substeps: 1
domain:
  min: [0.0, 0.0, 0.0]
  max: [0.21, 0.21, 0.2]
fluid:
  particle_spacing: 0.01
  speed_of_sound: 15
  artificial_viscosity: 0
  blocks:
    - min: [0.0, 0.0, 0.0]
      max: [0.21, 0.21, 0.18]
rigid_bodies:
  - name: ball
    shape: sphere
    radius: 0.03
    density: 1000
    position: [{x0}, {y0}, {z0}]
    motion:
      type: keyframes
      keyframes:
""" + "\n".join(keys) + """
output:
  particles: true
  step_forces: true
""")
