#!/usr/bin/env python3
"""Writes a closed bowl mesh (OBJ) for rigid-body scenes: a thick hemispherical shell with a flat rim.

The bowl is a surface of revolution about z. Its profile runs from the outer south pole up the
outer sphere (radius R_out) to the rim plane z = 0, across the flat rim to the inner sphere
(radius R_in), and down the inner sphere to the inner south pole. The cavity opens upward; the
rim lies in the plane z = 0, the outer bottom at z = -R_out. Triangles face outward from the solid
(counter-clockwise seen from outside), every edge is shared by exactly two triangles (closed).

Usage: scripts/make_bowl_obj.py [--inner 0.08] [--outer 0.095] [--segments 48] [--rings 12] OUT.obj
Committed output: scenes/meshes/bowl.obj (the defaults).
"""
import argparse
import math


def profile(r_in, r_out, rings):
    pts = []
    for j in range(rings + 1):  # outer sphere: south pole (r = 0) up to the rim
        t = 0.5 * math.pi * j / rings
        pts.append((0.0 if j == 0 else r_out * math.sin(t), -r_out * math.cos(t)))
    for j in range(rings + 1):  # inner sphere: rim down to the south pole
        t = 0.5 * math.pi * (rings - j) / rings
        pts.append((0.0 if j == rings else r_in * math.sin(t), -r_in * math.cos(t)))
    return pts


def lathe(pts, n):
    verts, first = [], []
    for r, z in pts:
        first.append(len(verts))
        if r <= 0.0:
            verts.append((0.0, 0.0, z))
        else:
            verts.extend((r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n), z) for k in range(n))

    def ring(i, k):
        return first[i] if pts[i][0] <= 0.0 else first[i] + k % n

    tris = []
    for i in range(len(pts) - 1):
        a, b = i, i + 1
        for k in range(n):
            # With the solid on the profile's left, (a_k, a_k+1, b_k+1) and (a_k, b_k+1, b_k) face outward.
            if pts[a][0] > 0.0:
                tris.append((ring(a, k), ring(a, k + 1), ring(b, k + 1)))
            if pts[b][0] > 0.0:
                tris.append((ring(a, k), ring(b, k + 1), ring(b, k)))
    return verts, tris


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--inner", type=float, default=0.08, help="inner radius (m)")
    ap.add_argument("--outer", type=float, default=0.095, help="outer radius (m)")
    ap.add_argument("--segments", type=int, default=48, help="vertices around each ring")
    ap.add_argument("--rings", type=int, default=12, help="rings per quarter circle")
    ap.add_argument("out")
    a = ap.parse_args()
    if not 0 < a.inner < a.outer:
        ap.error("need 0 < inner < outer")
    verts, tris = lathe(profile(a.inner, a.outer, a.rings), a.segments)
    with open(a.out, "w") as f:
        f.write("# bowl: inner radius %g m, outer radius %g m, rim at z = 0 (scripts/make_bowl_obj.py)\n" % (a.inner, a.outer))
        for v in verts:
            f.write("v %.6f %.6f %.6f\n" % v)
        for t in tris:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))


if __name__ == "__main__":
    main()
