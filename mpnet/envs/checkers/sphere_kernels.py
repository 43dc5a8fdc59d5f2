"""The compiled core of the sphere checker (numba): spheres posed by the arm's forward
kinematics (mpnet.envs.arm.kinematics) against oriented boxes, cylinders and spheres,
self-collision sphere pairs, and a state's verdict (the checks of states and certified
motions built on it: sphere_checks).

Why numba: a sampling planner asks about one configuration at a time from Python, and a
configuration is ~13 frame transforms and a few hundred sphere tests with early exits, which
numpy cannot batch without paying ~30 us of call overhead; compiled, one costs ~1-2 us.

The model (packed by mpnet.envs.checkers.spheres.SphereModel; its layout, the views'
indices and the scratch: sphere_layout): frames in parent-before-child order; a three-level
sphere tree of links, groups and spheres; the self-collision link pairs; and, for every
sphere, group and link, a lever per joint: a bound on how far its centre moves per radian
of that joint. A test descends the tree only where a bounding sphere touches, so a
configuration far from everything costs a few dozen tests, not thousands.

A state's verdict is one of FREE (free even with every sphere grown by its `extra`),
NEAR (a grown sphere touches something, and no sphere touches at q), HIT (a sphere touches
an obstacle or another link) or NEAR_HIT (a HIT found after a grown contact: the motion
counts it as it counts a NEAR's plain check). After the first grown contact the scan goes on
plain: the answer is the one a grown scan and then a plain scan of q would give.
"""

from __future__ import annotations

import math

import numpy as np

from mpnet.envs.arm.kinematics import forward
from mpnet.envs.checkers.hull_kernels import BULLET_MARGIN, JUDGE_TOLERANCE, hull_gap
from mpnet.envs.checkers.sphere_bounds import growth, growth_from, growths
from mpnet.envs.checkers.sphere_layout import (
    AXDIR,
    AXIS,
    AXPOINT,
    BLOCAL,
    BOUND,
    BRADIUS,
    CENTRES,
    COORD,
    FIRST,
    GA,
    GB,
    GCENTRES,
    GEXTRA,
    GLEVER,
    GLOCAL,
    GNJ,
    GPLACED,
    GRADIUS,
    GREL,
    GROUP_FRAME,
    GROUP_S0,
    GROUP_S1,
    GSPEED,
    HULL,
    KIND,
    LA,
    LB,
    LCENTRES,
    LEXTRA,
    LINK_FRAME,
    LINK_G0,
    LINK_G1,
    LINK_H0,
    LINK_H1,
    LINK_HR,
    LLEVER,
    LNJ,
    LOCAL,
    LPLACED,
    LREL,
    LSPEED,
    ORIGIN,
    PAIR_A,
    PAIR_B,
    PAIR_EXACT,
    PAIR_J0,
    PAIR_TABLE,
    PARENT,
    PG,
    POSE,
    PRIS,
    RADIUS,
    SDQ,
    TABLE_F,
    TABLE_I,
    TABLE_SUM,
    TOP,
    unpack,
    unpack_buffers,
)
from mpnet.jit import njit

FREE, NEAR, HIT, NEAR_HIT = 0, 1, 2, 3  # NEAR_HIT: a grown contact, then a sphere touching at q


def _obstacles(ob):
    """(boxes (B, 15), cylinders (C, 8), balls (K, 4), margin, bounds (B + C + K, 6)) from
    [B, C, K, margin, ...]; bounds: each obstacle's axis-aligned box (low, high), boxes'
    first, a test of 6 comparisons that rejects most (link, obstacle) pairs before _dist2."""
    nb, nc, nk = int(ob[0]), int(ob[1]), int(ob[2])
    o = 4
    boxes = ob[o : o + 15 * nb].reshape((nb, 15))
    o += 15 * nb
    cyls = ob[o : o + 8 * nc].reshape((nc, 8))
    o += 8 * nc
    balls = ob[o : o + 4 * nk].reshape((nk, 4))
    o += 4 * nk
    bounds = ob[o : o + 6 * (nb + nc + nk)].reshape((nb + nc + nk, 6))
    return boxes, cyls, balls, ob[3], bounds


unpack_obstacles = njit(cache=True, borrowed=True)(_obstacles)  # for borrowed kernels (mpnet.jit)
obstacle_views = njit(cache=True)(_obstacles)  # the same, for Python and counting kernels


@njit(cache=True, borrowed=True)
def _place(pose, f, local, k, out, o):
    for i in range(3):
        out[o, i] = (
            pose[f, i, 0] * local[k, 0] + pose[f, i, 1] * local[k, 1] + pose[f, i, 2] * local[k, 2] + pose[f, i, 3]
        )


@njit(cache=True, borrowed=True)
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


@njit(cache=True, borrowed=True)
def _outside(p, o, bounds, row, reach):
    """Is point p[o] farther than reach from axis-aligned box `row` along some axis?"""
    b = bounds[row]
    for x in range(3):
        if p[o, x] < b[x] - reach or p[o, x] > b[3 + x] + reach:
            return True
    return False


@njit(cache=True, borrowed=True)
def _place_groups(li, m, bufs, grow, growing, need):
    """The centres of link li's groups, once per configuration, and, in a motion where `need`
    says they are read, their growth, once (LPLACED: 0 nothing yet, 1 centres, 2 centres and
    growth; a plain check's growth is 0). A link tested against a link below it in a motion
    grows by nothing: its groups' growth is then not computed."""
    placed = bufs[LPLACED][li]
    gextra = bufs[GEXTRA]
    if placed == 0.0:
        pose, gcentres = bufs[POSE], bufs[GCENTRES]
        for g in range(m[LINK_G0][li], m[LINK_G1][li]):
            _place(pose, m[GROUP_FRAME][g], m[GLOCAL], g, gcentres, g)
            if not growing:
                gextra[g] = 0.0
        placed = 1.0 if growing else 2.0
    if placed == 1.0 and need:
        bound, gc, gr, gnj, gs, gb, ga = m[BOUND], bufs[GCENTRES], m[GRADIUS], m[GNJ], bufs[GSPEED], bufs[GB], bufs[GA]
        for g in range(m[LINK_G0][li], m[LINK_G1][li]):
            gextra[g] = growth(bound, gc, g, gr, gnj, grow, gs, gb, ga, bufs[GREL])
        placed = 2.0
    bufs[LPLACED][li] = placed


@njit(cache=True, borrowed=True)
def _place_spheres(g, m, bufs):
    """The centres of group g's spheres, once per configuration."""
    if bufs[GPLACED][g] == 0.0:
        pose, centres = bufs[POSE], bufs[CENTRES]
        f = m[GROUP_FRAME][g]
        for k in range(m[GROUP_S0][g], m[GROUP_S1][g]):
            _place(pose, f, m[LOCAL], k, centres, k)
        bufs[GPLACED][g] = 1.0


@njit(cache=True, borrowed=True)
def _apart(p, i, rp, c, j, rc, reach):
    """Are point p[i] and point c[j] farther apart than rp[i] + rc[j] + reach?"""
    d2 = 0.0
    for x in range(3):
        d2 += (p[i, x] - c[j, x]) ** 2
    r = rp[i] + rc[j] + reach
    return d2 > r * r


@njit(cache=True, borrowed=True)
def _axes(m, pose, ap, au, pris):
    """Each joint's axis in the base frame now: a point on it, its direction, prismatic flag."""
    coord, kind, axis = m[COORD], m[KIND], m[AXIS]
    for f in range(coord.shape[0]):
        j = coord[f]
        if j < 0:
            continue
        pris[j] = 1.0 if kind[f] == 2 else 0.0
        for x in range(3):
            ap[j, x] = pose[f, x, 3]
            au[j, x] = pose[f, x, 0] * axis[f, 0] + pose[f, x, 1] * axis[f, 1] + pose[f, x, 2] * axis[f, 2]


@njit(cache=True, borrowed=True)
def _cell(v, lo, width, n):
    c = int(math.floor((v - lo) / width))
    return 0 if c < 0 else (n - 1 if c >= n else c)


@njit(cache=True, borrowed=True)
def _table_free(q, ti, tf, counts, h, dq):
    """Does pair table ti certify its pairs free for every joint vector within h dq of q?
    ti = (joint a, joint b or -1, cells along a, cells along b, its first entry in counts);
    tf = (low a, cell width a, low b, cell width b). counts: each table's summed-area counts
    of the cells that are not free ((cells a + 1) x (cells b + 1): entry [i, k] counts the
    cells below i along a and below k along b; build_table says which cells are free), so a
    box of any number of cells is read in four entries: a long motion interval is answered
    by the table as a short one is (checker VERSION 3; VERSION 2 read at most 16 cells and
    tested the spheres of a longer one)."""
    ja, jb, na, nb, off = ti[0], ti[1], ti[2], ti[3], ti[4]
    i0 = _cell(q[ja] - h * dq[ja], tf[0], tf[1], na)
    i1 = _cell(q[ja] + h * dq[ja], tf[0], tf[1], na) + 1
    k0, k1 = 0, 1
    if jb >= 0:
        k0 = _cell(q[jb] - h * dq[jb], tf[2], tf[3], nb)
        k1 = _cell(q[jb] + h * dq[jb], tf[2], tf[3], nb) + 1
    w = nb + 1
    lo, hi = off + i0 * w, off + i1 * w
    return counts[hi + k1] - counts[lo + k1] - counts[hi + k0] + counts[lo + k0] == 0


@njit(cache=True)
def build_table(mi, mf, buf, lever, a, partners, ja, jb, lo, width, n):
    """The bits of a pair table: link a against each link of `partners`, whose poses
    relative to a depend on joints ja and jb alone (jb -1: ja alone), on an n[0] x n[1] grid
    of cells of `width` from `lo`. A cell's bit is set when, at its centre, every sphere of
    a partner, grown by how far it can move within the cell (sum over the two joints of
    half the cell's width times its static lever, which bounds its distance from that
    joint's axis in any configuration), clears every sphere of a. The other joints are held
    at 0: they move a and its partners together."""
    bits = np.zeros((n[0] * n[1] + 63) // 64, np.int64)
    _fill_table(mi, mf, buf, lever, a, partners, ja, jb, lo, width, n, np.zeros(lever.shape[1]), bits)
    return bits


@njit(cache=True, borrowed=True)
def _fill_table(mi, mf, buf, lever, a, partners, ja, jb, lo, width, n, q, bits):
    """build_table's cells, into bits (q: a joint vector of zeros, scratch)."""
    m, bufs = unpack(mi, mf), unpack_buffers(mi, buf)
    pose, centres, gcentres = bufs[POSE], bufs[CENTRES], bufs[GCENTRES]
    link_g0, link_g1, group_s0, group_s1 = m[LINK_G0], m[LINK_G1], m[GROUP_S0], m[GROUP_S1]
    radius, gradius, glever = m[RADIUS], m[GRADIUS], m[GLEVER]
    hb = 0.5 * width[1] if jb >= 0 else 0.0
    for i in range(n[0]):
        for k in range(n[1]):
            q[ja] = lo[0] + (i + 0.5) * width[0]
            if jb >= 0:
                q[jb] = lo[1] + (k + 0.5) * width[1]
            forward(q, m[PARENT], m[ORIGIN], m[KIND], m[AXIS], m[COORD], pose)
            free = True
            for g in range(link_g0[a], link_g1[a]):
                _place(pose, m[GROUP_FRAME][g], m[GLOCAL], g, gcentres, g)
                for s in range(group_s0[g], group_s1[g]):
                    _place(pose, m[GROUP_FRAME][g], m[LOCAL], s, centres, s)
            for b in partners:
                for gb in range(link_g0[b], link_g1[b]):
                    _place(pose, m[GROUP_FRAME][gb], m[GLOCAL], gb, gcentres, gb)
                    for s in range(group_s0[gb], group_s1[gb]):
                        _place(pose, m[GROUP_FRAME][gb], m[LOCAL], s, centres, s)
                    grow = 0.5 * width[0] * (glever[gb, ja] + gradius[gb])
                    if jb >= 0:
                        grow += hb * (glever[gb, jb] + gradius[gb])
                    for ga in range(link_g0[a], link_g1[a]):
                        if not free or _apart(gcentres, ga, gradius, gcentres, gb, gradius, grow):
                            continue
                        for x in range(group_s0[ga], group_s1[ga]):
                            for y in range(group_s0[gb], group_s1[gb]):
                                sg = 0.5 * width[0] * lever[y, ja] + (hb * lever[y, jb] if jb >= 0 else 0.0)
                                if not _apart(centres, x, radius, centres, y, radius, sg):
                                    free = False
            if free:
                c = i * n[1] + k
                bits[c >> 6] |= np.int64(1) << np.int64(c & 63)


@njit(cache=True, borrowed=True)
def _hulls_hit(m, pose, a, b, grown):
    """Links a and b on the judge's shapes (an exact pair: convex cores, each grown by its
    LINK_HR, a sphere's radius or pybullet's margin): 0 apart by more than `grown`, 1 apart,
    but not by `grown`, 2 maybe touching (hull_kernels.hull_gap's lower
    bound decides: never apart on GJK's estimate)."""
    h0, h1, hull, frame = m[LINK_H0], m[LINK_H1], m[HULL], m[LINK_FRAME]
    fa, fb = frame[a], frame[b]
    ra, ta, rb, tb = pose[fa, :, :3], pose[fa, :, 3], pose[fb, :, :3], pose[fb, :, 3]
    radii = m[LINK_HR][a] + m[LINK_HR][b]  # the cores' gap less how far the judge's shapes reach beyond them
    target = JUDGE_TOLERANCE + grown + radii
    gap = hull_gap(hull, h0[a], h1[a], ra, ta, h0[b], h1[b], rb, tb, target)
    if gap > target:
        return 0
    plain = JUDGE_TOLERANCE + radii
    if grown > 0.0 and gap <= plain:  # it stopped at `target`: the plain question asked afresh
        gap = hull_gap(hull, h0[a], h1[a], ra, ta, h0[b], h1[b], rb, tb, plain)
    return 1 if grown > 0.0 and gap > plain else 2


@njit(cache=True, borrowed=True, inline="always")
def verdict(q, m, obs, bufs, growing, h, dq):
    """FREE, NEAR, HIT or NEAR_HIT for configuration q (see the module docstring). `growing`: q is
    the midpoint of a motion interval of half-width h (in the motion's parameter) along
    joint steps dq; every sphere, group and link is grown by how far it can move in it.

    Growing, NEAR means a grown sphere touches and no sphere touches at q itself: at the
    first grown contact the scan goes on at the plain level (the growth multiplied by
    `on` = 0) from where it is, for a HIT. Everything before that point cleared its grown
    test, so cleared the plain one: the answer is a plain check's, from one pose and one
    scan, not two."""
    boxes, cyls, balls, margin, bounds = obs
    pose, centres, lcentres, gcentres = bufs[POSE], bufs[CENTRES], bufs[LCENTRES], bufs[GCENTRES]
    lextra, gextra = bufs[LEXTRA], bufs[GEXTRA]
    link_g0, link_g1, group_s0, group_s1 = m[LINK_G0], m[LINK_G1], m[GROUP_S0], m[GROUP_S1]
    radius, bradius, gradius = m[RADIUS], m[BRADIUS], m[GRADIUS]
    forward(q, m[PARENT], m[ORIGIN], m[KIND], m[AXIS], m[COORD], pose)
    ap, au, pris = bufs[AXPOINT], bufs[AXDIR], bufs[PRIS]
    if growing:
        _axes(m, pose, ap, au, pris)
    bound, lspeed, lrel = m[BOUND], bufs[LSPEED], bufs[LREL]
    grow = (h, dq, ap, au, pris, bufs[SDQ])
    L = link_g0.shape[0]
    for li in range(L):
        _place(pose, m[LINK_FRAME][li], m[BLOCAL], li, lcentres, li)
        lextra[li] = 0.0
        bufs[LPLACED][li] = 0.0
    if growing:
        growths(bound, lcentres, bradius, m[LNJ], grow, lspeed, bufs[LB], bufs[LA], lrel, lextra)
    top = 0.0
    for li in range(L):
        top = max(top, lextra[li])
    bufs[GPLACED][:] = 0.0
    bufs[TOP][0] = top
    on = 1.0 if growing else 0.0  # 0 once a grown contact is found: plain from there on
    counts = (boxes.shape[0], cyls.shape[0], balls.shape[0])
    for li in range(m[FIRST], L):
        row = 0
        for ok in range(3):
            for j in range(counts[ok]):
                row += 1
                reach = bradius[li] + lextra[li] * on + margin
                if _outside(lcentres, li, bounds, row - 1, reach):
                    continue
                if _dist2(lcentres, li, boxes, cyls, balls, ok, j) > reach * reach:
                    continue
                _place_groups(li, m, bufs, grow, growing, on != 0.0)
                for g in range(link_g0[li], link_g1[li]):
                    reach = gradius[g] + gextra[g] * on + margin
                    if _outside(gcentres, g, bounds, row - 1, reach):
                        continue
                    if _dist2(gcentres, g, boxes, cyls, balls, ok, j) > reach * reach:
                        continue
                    _place_spheres(g, m, bufs)
                    for k in range(group_s0[g], group_s1[g]):
                        d2 = _dist2(centres, k, boxes, cyls, balls, ok, j)
                        r = radius[k] + margin
                        if d2 <= r * r:
                            return NEAR_HIT if growing and on == 0.0 else HIT
                        r += gextra[g] * on
                        if d2 <= r * r:
                            on = 0.0
    pair_a, pair_b, pair_j0, pg = m[PAIR_A], m[PAIR_B], m[PAIR_J0], bufs[PG]
    looked_up, looked_on, table_says_free = -1, on, False  # a table's pairs are consecutive: one lookup serves them
    for pi in range(pair_a.shape[0]):
        a, b, j0 = pair_a[pi], pair_b[pi], pair_j0[pi]
        t = m[PAIR_TABLE][pi]
        if t >= 0 and (t != looked_up or looked_on != on):
            looked_up, looked_on = t, on
            table_says_free = _table_free(q, m[TABLE_I][t], m[TABLE_F][t], m[TABLE_SUM], h * on, dq)
        if t >= 0 and table_says_free:
            continue
        # In a motion, link b moves relative to link a (its ancestor) only through the joints
        # between them: b grows by that, a not at all. Otherwise both grow by their own motion.
        rel = on != 0.0 and j0 >= 0
        if rel:
            ra, rb = 0.0, growth_from(bound, b, bradius, m[LLEVER], j0, grow, lspeed, lrel)
        else:
            ra, rb = lextra[a] * on, lextra[b] * on
        if m[PAIR_EXACT][pi]:
            if _apart(lcentres, a, bradius, lcentres, b, bradius, ra + rb + 2 * BULLET_MARGIN):
                continue
            hit = _hulls_hit(m, pose, a, b, ra + rb)
            if hit == 0:
                continue
            if hit == 1:  # apart, but not by the growth
                on = 0.0
                continue
            return NEAR_HIT if growing and on == 0.0 else HIT
        if _apart(lcentres, a, bradius, lcentres, b, bradius, ra + rb):
            continue
        _place_groups(a, m, bufs, grow, growing, on != 0.0 and not rel)
        _place_groups(b, m, bufs, grow, growing, on != 0.0)
        a_grow = 0.0  # the largest growth of a group of a
        if not rel:
            for ga in range(link_g0[a], link_g1[a]):
                a_grow = max(a_grow, gextra[ga] * on)
        for gb in range(link_g0[b], link_g1[b]):
            if rel:
                pg[gb] = growth_from(bound, gb, gradius, m[GLEVER], j0, grow, bufs[GSPEED], bufs[GREL])
            else:
                pg[gb] = gextra[gb] * on
            # a group of b out of reach of a's bounding sphere is out of reach of each of its groups
            if _apart(gcentres, gb, gradius, lcentres, a, bradius, pg[gb] + a_grow):
                pg[gb] = -1.0
        # Every growth below is multiplied by `on`: a grown contact found in this pair makes
        # the rest of it plain too.
        for ga in range(link_g0[a], link_g1[a]):
            ga_grow = 0.0 if rel else gextra[ga]
            if _apart(gcentres, ga, gradius, lcentres, b, bradius, (ga_grow + rb) * on):
                continue
            for gb in range(link_g0[b], link_g1[b]):
                if pg[gb] < 0.0:
                    continue
                grown = ga_grow + pg[gb]
                if _apart(gcentres, ga, gradius, gcentres, gb, gradius, grown * on):
                    continue
                _place_spheres(ga, m, bufs)
                _place_spheres(gb, m, bufs)
                for k in range(group_s0[ga], group_s1[ga]):
                    if _apart(centres, k, radius, gcentres, gb, gradius, grown * on):
                        continue
                    for n in range(group_s0[gb], group_s1[gb]):
                        if not _apart(centres, k, radius, centres, n, radius, 0.0):
                            return NEAR_HIT if growing and on == 0.0 else HIT
                        if on != 0.0 and not _apart(centres, k, radius, centres, n, radius, grown):
                            on = 0.0
    return NEAR if growing and on == 0.0 else FREE
