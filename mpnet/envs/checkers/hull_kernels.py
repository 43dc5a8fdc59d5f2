"""The distance between two convex hulls (GJK), bounded from below: the arm's exact self-pairs.

A sphere covering inflates each link by a few millimetres, so two links that pass within
millimetres of each other in every configuration (the UR5's forearm and second wrist link,
whose hulls are what pybullet tests) are refused where the judge accepts them, and motions
near their contact are never certified. A robot description names such pairs
(`exact_pairs`); the checker tests them on the hulls' vertices instead.

GJK (Gilbert, Johnson, Keerthi 1988) walks a simplex of the Minkowski difference A - B
toward the origin. Every direction v it tries bounds the distance from below: no point of
A - B lies closer to the origin along v than min over A - B of x . v / |v|, which is
exact arithmetic on the vertices (the support points), whatever the iteration reached. A
pair is certified apart by that lower bound, never by GJK's estimate, so a slow or stopped
iteration can refuse a free state but never accept a colliding one."""

from __future__ import annotations

import math

import numpy as np

from mpnet.jit import njit

ITERATIONS = 64  # GJK's steps at most (a polytope pair converges in a handful)
# pybullet pads each convex hull (a mesh's, a box's) by a collision margin of 1 mm; a sphere is
# itself. Measured: pybullet's distance is the shapes' less 1.93-1.99 mm between two meshes (the
# UR5's forearm and wrist, base and upper arm; a Fetch pair) and less 0.98-1.00 mm between a mesh
# and a sphere (the Fetch's head and torso spheres): a pair is apart for the judge only beyond
# both margins (SphereModel._hulls adds each link's to its radius) and this tolerance
# (tests/mpnet/envs/arm/test_robot_files.py holds the checker to pybullet's answers)
BULLET_MARGIN = 0.001
JUDGE_TOLERANCE = 2e-5


@njit(cache=True, inline="always")
def _support(verts, v0, v1, R, t, d0, d1, d2):
    """The vertex of hull verts[v0:v1] (local coordinates, posed by R, t) farthest along
    world direction d, in world coordinates."""
    l0 = R[0, 0] * d0 + R[1, 0] * d1 + R[2, 0] * d2
    l1 = R[0, 1] * d0 + R[1, 1] * d1 + R[2, 1] * d2
    l2 = R[0, 2] * d0 + R[1, 2] * d1 + R[2, 2] * d2
    best, bi = -np.inf, v0
    for i in range(v0, v1):
        s = verts[i, 0] * l0 + verts[i, 1] * l1 + verts[i, 2] * l2
        if s > best:
            best, bi = s, i
    x, y, z = verts[bi, 0], verts[bi, 1], verts[bi, 2]
    return (
        R[0, 0] * x + R[0, 1] * y + R[0, 2] * z + t[0],
        R[1, 0] * x + R[1, 1] * y + R[1, 2] * z + t[1],
        R[2, 0] * x + R[2, 1] * y + R[2, 2] * z + t[2],
    )


@njit(cache=True, inline="always")
def _dot(s, i, j, o):
    """(s[i] - s[o]) . (s[j] - s[o])"""
    return (
        (s[i, 0] - s[o, 0]) * (s[j, 0] - s[o, 0])
        + (s[i, 1] - s[o, 1]) * (s[j, 1] - s[o, 1])
        + (s[i, 2] - s[o, 2]) * (s[j, 2] - s[o, 2])
    )


@njit(cache=True)
def _closest(simplex, n, out_w, idx, lam, G, r):
    """The point of the simplex's hull (its first n rows, n <= 4) closest to the origin, and
    its barycentric weights in out_w: every face of the simplex tried (15 at most), the
    nearest projection onto a face's affine hull whose weights are all positive kept (each
    is a point of the simplex, and the closest point is one of them). idx, lam, G, r: scratch."""
    best = np.inf
    bx = by = bz = 0.0
    for mask in range(1, 1 << n):
        k = 0
        for i in range(n):
            if mask >> i & 1:
                idx[k] = i
                k += 1
        o = idx[0]
        # weights lam of the edges e_j = p_j - p_o minimising |p_o + sum lam_j e_j|:
        # the Gram system G lam = -(e . p_o), solved by Cramer's rule (k - 1 <= 3)
        if k == 1:
            lam[0] = 0.0
        elif k == 2:
            g = _dot(simplex, idx[1], idx[1], o)
            if g < 1e-24:
                continue
            lam[0] = -_origin_dot(simplex, idx[1], o) / g
        else:
            m = k - 1
            for a in range(m):
                r[a] = -_origin_dot(simplex, idx[a + 1], o)
                for b in range(m):
                    G[a, b] = _dot(simplex, idx[a + 1], idx[b + 1], o)
            if m == 2:
                det = G[0, 0] * G[1, 1] - G[0, 1] * G[1, 0]
                if abs(det) < 1e-30:
                    continue
                lam[0] = (r[0] * G[1, 1] - G[0, 1] * r[1]) / det
                lam[1] = (G[0, 0] * r[1] - r[0] * G[1, 0]) / det
            else:
                det = _det3(G, 0, 1, 2)
                if abs(det) < 1e-36:
                    continue
                for c in range(3):
                    saved0, saved1, saved2 = G[0, c], G[1, c], G[2, c]
                    G[0, c], G[1, c], G[2, c] = r[0], r[1], r[2]
                    lam[c] = _det3(G, 0, 1, 2) / det
                    G[0, c], G[1, c], G[2, c] = saved0, saved1, saved2
        w0 = 1.0
        for a in range(k - 1):
            w0 -= lam[a]
        ok = w0 > 0.0
        for a in range(k - 1):
            ok = ok and lam[a] > 0.0
        if k > 1 and not ok:
            continue
        x, y, z = simplex[o, 0], simplex[o, 1], simplex[o, 2]
        for a in range(k - 1):
            j = idx[a + 1]
            x += lam[a] * (simplex[j, 0] - simplex[o, 0])
            y += lam[a] * (simplex[j, 1] - simplex[o, 1])
            z += lam[a] * (simplex[j, 2] - simplex[o, 2])
        d = x * x + y * y + z * z
        if d < best:
            best, bx, by, bz = d, x, y, z
            out_w[:] = 0.0
            out_w[o] = w0 if k > 1 else 1.0
            for a in range(k - 1):
                out_w[idx[a + 1]] = lam[a]
    return bx, by, bz


@njit(cache=True, inline="always")
def _origin_dot(s, i, o):
    """(s[i] - s[o]) . s[o]"""
    return (s[i, 0] - s[o, 0]) * s[o, 0] + (s[i, 1] - s[o, 1]) * s[o, 1] + (s[i, 2] - s[o, 2]) * s[o, 2]


@njit(cache=True, inline="always")
def _det3(G, a, b, c):
    return (
        G[a, 0] * (G[b, 1] * G[c, 2] - G[b, 2] * G[c, 1])
        - G[a, 1] * (G[b, 0] * G[c, 2] - G[b, 2] * G[c, 0])
        + G[a, 2] * (G[b, 0] * G[c, 1] - G[b, 1] * G[c, 0])
    )


@njit(cache=True)
def hull_gap(verts, a0, a1, Ra, ta, b0, b1, Rb, tb, target):
    """A lower bound on the distance between hull A (verts[a0:a1] posed by Ra, ta) and hull B
    (verts[b0:b1] posed by Rb, tb): exact to GJK's tolerance when it converges; it stops
    early once the bound exceeds `target` (the caller's need) or the distance is shown to
    be at most target (target NaN: to convergence). 0 (or less) when the hulls may touch."""
    simplex = np.empty((4, 3))
    w, lam, idx, G, r = np.zeros(4), np.zeros(3), np.zeros(4, np.int64), np.zeros((3, 3)), np.zeros(3)
    ax, ay, az = _support(verts, a0, a1, Ra, ta, 1.0, 0.0, 0.0)
    bx, by, bz = _support(verts, b0, b1, Rb, tb, -1.0, 0.0, 0.0)
    vx, vy, vz = ax - bx, ay - by, az - bz
    n = 0
    lower = -np.inf
    for _ in range(ITERATIONS):
        norm = math.sqrt(vx * vx + vy * vy + vz * vz)
        if norm < 1e-12:
            return 0.0
        # the point of A - B farthest along -v: a's support along -v minus b's along v
        ax, ay, az = _support(verts, a0, a1, Ra, ta, -vx, -vy, -vz)
        bx, by, bz = _support(verts, b0, b1, Rb, tb, vx, vy, vz)
        px, py, pz = ax - bx, ay - by, az - bz
        lower = max(lower, (px * vx + py * vy + pz * vz) / norm)
        if lower > target or norm <= target or norm - lower <= 1e-9:
            return lower
        simplex[n, 0], simplex[n, 1], simplex[n, 2] = px, py, pz
        n += 1
        vx, vy, vz = _closest(simplex, n, w, idx, lam, G, r)
        k = 0
        for i in range(n):  # keep the vertices the closest point uses
            if w[i] > 0.0:
                simplex[k] = simplex[i]
                k += 1
        n = k
        if n == 4:
            return min(lower, 0.0)
    return lower
