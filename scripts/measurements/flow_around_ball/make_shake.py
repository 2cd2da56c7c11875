#!/usr/bin/env python3
"""accel_ball.yaml's tank with the ball shaken at another frequency (session 15): x = x0 + A (1 - cos w (t - 0.3 s)),
keyframes every KEY s for N periods, run to the end of the shaking.  usage: make_shake.py F_HZ A_M N KEY_S OUT.yaml"""
import sys, re, math
f, A, N, key, out = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
s = open("scenes/tests/accel_ball.yaml").read()
T = N / f
n = int(round(T / key))
keys = "".join(f"        - {{time: {0.3 + k * key:.6f}, position: [{0.105 + A * (1 - math.cos(2 * math.pi * f * k * key)):.9f}, 0.105, 0.08]}}\n"
               for k in range(n + 1))
s = re.sub(r"      keyframes:[^\n]*\n(        - \{time[^\n]*\n)+", "      keyframes:\n" + keys, s, flags=re.S)  # (keys: one line each)
s = re.sub(r"  duration: 0\.5 ", f"  duration: {0.3 + T:.6f} ", s)
open(out, "w").write(s)
