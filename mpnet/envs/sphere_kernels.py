"""The compiled core of the sphere checker (numba): forward kinematics, spheres against
oriented boxes, cylinders and spheres, self-collision sphere pairs, and certified motions.

Why numba: a sampling planner asks about one configuration at a time from Python, and a
configuration is ~13 frame transforms and a few hundred sphere tests with early exits, which
numpy cannot batch without paying ~30 us of call overhead; compiled, one costs ~1-2 us.

Data layout (built by mpnet.envs.spheres.SphereModel): frames in parent-before-child order
(`parent`, `origin` (F, 3, 4), `kind`, `axis`, `coord`), spheres grouped by link
(`link_frame`, `link_start`, `link_end`, `local` (S, 3), `radius`), each link's bounding
sphere (`blocal`, `bradius`), the self-collision link pairs, and per sphere and per link a
lever (S, dof): a bound on how far the sphere's centre moves per radian of each joint.

A state's verdict is one of FREE (free even with every sphere grown by its `extra`),
NEAR (free, but not with the growth) or HIT (a sphere touches an obstacle or another link).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

FREE, NEAR, HIT = 0, 1, 2
QUEUE = 1 << 14  # motion intervals pending at once; a motion that needs more is called blocked


HEAD = 6  # mi starts with F, L, S, P, D, first


@njit(cache=True)
def unpack(mi, mf):
    """The model's arrays as views of its two packed arrays (one int64, one float64: two
    arguments dispatch from Python in well under a microsecond, a tuple of 15 does not)."""
    F, L, S, P, D, first = mi[0], mi[1], mi[2], mi[3], mi[4], mi[5]
    o = HEAD
    parent = mi[o : o + F]
    kind = mi[o + F : o + 2 * F]
    coord = mi[o + 2 * F : o + 3 * F]
    o += 3 * F
    link_frame = mi[o : o + L]
    link_start = mi[o + L : o + 2 * L]
    link_end = mi[o + 2 * L : o + 3 * L]
    o += 3 * L
    pair_a = mi[o : o + P]
    pair_b = mi[o + P : o + 2 * P]
    o = 0
    origin = mf[o : o + 12 * F].reshape((F, 3, 4))
    o += 12 * F
    axis = mf[o : o + 3 * F].reshape((F, 3))
    o += 3 * F
    local = mf[o : o + 3 * S].reshape((S, 3))
    o += 3 * S
    radius = mf[o : o + S]
    o += S
    blocal = mf[o : o + 3 * L].reshape((L, 3))
    o += 3 * L
    bradius = mf[o : o + L]
    o += L
    lever = mf[o : o + S * D].reshape((S, D))
    o += S * D
    llever = mf[o : o + L * D].reshape((L, D))
    return (parent, origin, kind, axis, coord, link_frame, link_start, link_end, local, radius, blocal, bradius,
            pair_a, pair_b, first, lever, llever)


@njit(cache=True)
def unpack_obstacles(ob):
    """(boxes (B, 15), cylinders (C, 8), balls (K, 4), margin) from [B, C, K, margin, ...]."""
    nb, nc, nk = int(ob[0]), int(ob[1]), int(ob[2])
    o = 4
    boxes = ob[o : o + 15 * nb].reshape((nb, 15))
    o += 15 * nb
    cyls = ob[o : o + 8 * nc].reshape((nc, 8))
    o += 8 * nc
    balls = ob[o : o + 4 * nk].reshape((nk, 4))
    return boxes, cyls, balls, ob[3]


@njit(cache=True)
def unpack_buffers(mi, buf):
    """Scratch views: poses (F + 1, 3, 4), sphere centres (S, 3), link centres (L, 3),
    placed flags (L), sphere growth (S), link growth (L), a joint vector (D)."""
    F, L, S, D = mi[0], mi[1], mi[2], mi[4]
    o = 0
    pose = buf[o : o + 12 * (F + 1)].reshape((F + 1, 3, 4))
    o += 12 * (F + 1)
    centres = buf[o : o + 3 * S].reshape((S, 3))
    o += 3 * S
    bcentres = buf[o : o + 3 * L].reshape((L, 3))
    o += 3 * L
    placed = buf[o : o + L]
    o += L
    extra = buf[o : o + S]
    o += S
    lextra = buf[o : o + L]
    o += L
    q = buf[o : o + D]
    return pose, centres, bcentres, placed, extra, lextra, q


def buffer_size(F: int, L: int, S: int, D: int) -> int:
    return 12 * (F + 1) + 3 * S + 3 * L + L + S + L + D



@njit(cache=True)
def forward(q, parent, origin, kind, axis, coord, out):
    """Every frame's pose (3 x 4, base frame) at joint vector q, into out[:F]; out[F] is
    scratch. Scalar loops throughout: array slicing costs more than the arithmetic here."""
    F = parent.shape[0]
    m = out[F]
    for f in range(F):
        for i in range(3):
            for j in range(4):
                m[i, j] = origin[f, i, j]
        c = coord[f]
        if c >= 0:
            v = q[c]
            if kind[f] == 1:
                x, y, z = axis[f, 0], axis[f, 1], axis[f, 2]
                cs, sn = math.cos(v), math.sin(v)
                C = 1.0 - cs
                r00, r01, r02 = cs + x * x * C, x * y * C - z * sn, x * z * C + y * sn
                r10, r11, r12 = y * x * C + z * sn, cs + y * y * C, y * z * C - x * sn
                r20, r21, r22 = z * x * C - y * sn, z * y * C + x * sn, cs + z * z * C
                for i in range(3):
                    a0, a1, a2 = origin[f, i, 0], origin[f, i, 1], origin[f, i, 2]
                    m[i, 0] = a0 * r00 + a1 * r10 + a2 * r20
                    m[i, 1] = a0 * r01 + a1 * r11 + a2 * r21
                    m[i, 2] = a0 * r02 + a1 * r12 + a2 * r22
            else:
                for i in range(3):
                    m[i, 3] += v * (origin[f, i, 0] * axis[f, 0] + origin[f, i, 1] * axis[f, 1] + origin[f, i, 2] * axis[f, 2])
        p = parent[f]
        if p < 0:
            for i in range(3):
                for j in range(4):
                    out[f, i, j] = m[i, j]
        else:
            for i in range(3):
                p0, p1, p2 = out[p, i, 0], out[p, i, 1], out[p, i, 2]
                for j in range(3):
                    out[f, i, j] = p0 * m[0, j] + p1 * m[1, j] + p2 * m[2, j]
                out[f, i, 3] = p0 * m[0, 3] + p1 * m[1, 3] + p2 * m[2, 3] + out[p, i, 3]


@njit(cache=True)
def _place(pose, f, local, k, out, o):
    for i in range(3):
        out[o, i] = pose[f, i, 0] * local[k, 0] + pose[f, i, 1] * local[k, 1] + pose[f, i, 2] * local[k, 2] + pose[f, i, 3]


@njit(cache=True)
def _dist2(p, o, boxes, cyls, balls, kind, j):
    """Squared distance from point p[o] to obstacle j of `kind` (0 box, 1 cylinder, 2 sphere)."""
    x, y, z = p[o, 0], p[o, 1], p[o, 2]
    if kind == 0:  # box: centre 0:3, rotation rows 3:12, half extents 12:15
        b = boxes[j]
        dx, dy, dz = x - b[0], y - b[1], z - b[2]
        s = 0.0
        for a in range(3):
            t = b[3 + 3 * a] * dx + b[4 + 3 * a] * dy + b[5 + 3 * a] * dz
            h = b[12 + a]
            if t > h:
                s += (t - h) ** 2
            elif t < -h:
                s += (t + h) ** 2
        return s
    if kind == 1:  # cylinder: centre 0:3, axis 3:6, radius 6, half height 7
        c = cyls[j]
        dx, dy, dz = x - c[0], y - c[1], z - c[2]
        t = dx * c[3] + dy * c[4] + dz * c[5]
        rx, ry, rz = dx - t * c[3], dy - t * c[4], dz - t * c[5]
        rad = math.sqrt(rx * rx + ry * ry + rz * rz) - c[6]
        s = rad * rad if rad > 0.0 else 0.0
        ax = abs(t) - c[7]
        if ax > 0.0:
            s += ax * ax
        return s
    s = balls[j]
    d = math.sqrt((x - s[0]) ** 2 + (y - s[1]) ** 2 + (z - s[2]) ** 2) - s[3]
    return d * d if d > 0.0 else 0.0


@njit(cache=True)
def verdict(q, m, obs, bufs):
    """FREE, NEAR or HIT for configuration q (see the module docstring); `extra` (S,) and
    `lextra` (L,) grow the spheres and the links' bounding spheres (zeros: a plain check)."""
    parent, origin, kind, axis, coord, link_frame, link_start, link_end, local, radius, blocal, bradius = m[:12]
    pair_a, pair_b, first = m[12], m[13], m[14]
    boxes, cyls, balls, margin = obs
    pose, centres, bcentres, placed, extra, lextra, _ = bufs
    forward(q, parent, origin, kind, axis, coord, pose)
    L = link_frame.shape[0]
    for li in range(L):
        _place(pose, link_frame[li], blocal, li, bcentres, li)
        placed[li] = 0.0
    near = False
    counts = (boxes.shape[0], cyls.shape[0], balls.shape[0])
    for li in range(first, L):
        for ok in range(3):
            for j in range(counts[ok]):
                reach = bradius[li] + lextra[li] + margin
                if _dist2(bcentres, li, boxes, cyls, balls, ok, j) > reach * reach:
                    continue
                if placed[li] == 0.0:
                    for k in range(link_start[li], link_end[li]):
                        _place(pose, link_frame[li], local, k, centres, k)
                    placed[li] = 1.0
                for k in range(link_start[li], link_end[li]):
                    d2 = _dist2(centres, k, boxes, cyls, balls, ok, j)
                    r = radius[k] + margin
                    if d2 <= r * r:
                        return HIT
                    r += extra[k]
                    if d2 <= r * r:
                        near = True
    for pi in range(pair_a.shape[0]):
        a, b = pair_a[pi], pair_b[pi]
        reach = bradius[a] + bradius[b] + lextra[a] + lextra[b]
        d2 = 0.0
        for i in range(3):
            d2 += (bcentres[a, i] - bcentres[b, i]) ** 2
        if d2 > reach * reach:
            continue
        for li in (a, b):
            if placed[li] == 0.0:
                for k in range(link_start[li], link_end[li]):
                    _place(pose, link_frame[li], local, k, centres, k)
                placed[li] = 1.0
        for k in range(link_start[a], link_end[a]):
            d2 = 0.0
            for i in range(3):
                d2 += (centres[k, i] - bcentres[b, i]) ** 2
            reach = radius[k] + extra[k] + bradius[b] + lextra[b]
            if d2 > reach * reach:  # sphere k is clear of all of link b
                continue
            for n in range(link_start[b], link_end[b]):
                d2 = 0.0
                for i in range(3):
                    d2 += (centres[k, i] - centres[n, i]) ** 2
                r = radius[k] + radius[n]
                if d2 <= r * r:
                    return HIT
                r += extra[k] + extra[n]
                if d2 <= r * r:
                    near = True
    return NEAR if near else FREE


@njit(cache=True)
def _state_free(q, m, obs, lower, upper, bufs):
    for d in range(q.shape[0]):
        if not lower[d] <= q[d] <= upper[d]:
            return False
    extra, lextra = bufs[4], bufs[5]
    extra[:] = 0.0
    lextra[:] = 0.0
    return verdict(q, m, obs, bufs) != HIT


@njit(cache=True)
def state_free(q, mi, mf, ob, lower, upper, buf):
    """In bounds and no sphere touching (a plain check)."""
    return _state_free(q, unpack(mi, mf), unpack_obstacles(ob), lower, upper, unpack_buffers(mi, buf))


@njit(cache=True)
def states_free(qs, mi, mf, ob, lower, upper, buf):
    """state_free for each row of qs."""
    m, obs, bufs = unpack(mi, mf), unpack_obstacles(ob), unpack_buffers(mi, buf)
    out = np.empty(qs.shape[0], np.bool_)
    for i in range(qs.shape[0]):
        out[i] = _state_free(qs[i], m, obs, lower, upper, bufs)
    return out


@njit(cache=True)
def _motion_free(a, b, m, obs, lower, upper, tol, bufs):
    """Is the straight joint motion a -> b free everywhere along it? Returns (free,
    configurations evaluated).

    Certified, not sampled: an interval [t0, t1] of the motion is free when its midpoint is
    free with every sphere grown by how far that sphere can move in half the interval
    (lever . |b - a| (t1 - t0) / 2), since no point of the sphere's sweep is farther than
    that from where it is at the midpoint. Intervals that are only NEAR are halved; a HIT
    at any midpoint, an interval whose growth is below `tol` metres and still NEAR, or more
    than QUEUE pending intervals, and the motion is called blocked. Joint limits are a box:
    the motion stays inside when its ends do."""
    for d in range(a.shape[0]):
        if not (lower[d] <= a[d] <= upper[d] and lower[d] <= b[d] <= upper[d]):
            return False, 0
    lever, llever = m[15], m[16]
    extra, lextra, q = bufs[4], bufs[5], bufs[6]
    S, L, D = lever.shape[0], llever.shape[0], a.shape[0]
    speed = np.zeros(S)
    lspeed = np.zeros(L)
    for d in range(D):
        step = abs(b[d] - a[d])
        for k in range(S):
            speed[k] += lever[k, d] * step
        for li in range(L):
            lspeed[li] += llever[li, d] * step
    top = 0.0
    for k in range(S):
        top = max(top, speed[k])
    evaluated = 0
    extra[:] = 0.0
    lextra[:] = 0.0
    for end in (b, a):  # the ends exactly first, where a blocked motion is most often found
        evaluated += 1
        if verdict(end, m, obs, bufs) == HIT:
            return False, evaluated
    t0s = np.empty(QUEUE)
    t1s = np.empty(QUEUE)
    head, tail = 0, 1
    t0s[0], t1s[0] = 0.0, 1.0
    while head != tail:
        t0, t1 = t0s[head % QUEUE], t1s[head % QUEUE]
        head += 1
        half = (t1 - t0) / 2
        mid = t0 + half
        for d in range(D):
            q[d] = a[d] + mid * (b[d] - a[d])
        for k in range(S):
            extra[k] = speed[k] * half
        for li in range(L):
            lextra[li] = lspeed[li] * half
        evaluated += 1
        v = verdict(q, m, obs, bufs)
        if v == FREE:
            continue
        if v == HIT or top * half < tol or tail - head + 2 > QUEUE:
            return False, evaluated
        t0s[tail % QUEUE], t1s[tail % QUEUE] = t0, mid
        tail += 1
        t0s[tail % QUEUE], t1s[tail % QUEUE] = mid, t1
        tail += 1
    return True, evaluated


@njit(cache=True)
def motion_free(a, b, mi, mf, ob, lower, upper, tol, buf):
    """Is the straight joint motion a -> b free everywhere along it? (free, configurations
    evaluated); see _motion_free."""
    return _motion_free(a, b, unpack(mi, mf), unpack_obstacles(ob), lower, upper, tol, unpack_buffers(mi, buf))


@njit(cache=True)
def motions_free(A, B, mi, mf, ob, lower, upper, tol, buf):
    """motion_free for each row pair (A[i], B[i]); also the configurations evaluated in all."""
    m, obs, bufs = unpack(mi, mf), unpack_obstacles(ob), unpack_buffers(mi, buf)
    out = np.empty(A.shape[0], np.bool_)
    total = 0
    for i in range(A.shape[0]):
        ok, n = _motion_free(A[i], B[i], m, obs, lower, upper, tol, bufs)
        total += n
        out[i] = ok
    return out, total


@njit(cache=True)
def any_hit(centres, radii, ob):
    """Does any sphere (centres, radii) touch an obstacle?"""
    boxes, cyls, balls, margin = unpack_obstacles(ob)
    counts = (boxes.shape[0], cyls.shape[0], balls.shape[0])
    for k in range(centres.shape[0]):
        for kind in range(3):
            for j in range(counts[kind]):
                r = radii[k] + margin
                if _dist2(centres, k, boxes, cyls, balls, kind, j) <= r * r:
                    return True
    return False
