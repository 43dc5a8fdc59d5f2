"""How the sphere checker's arrays are packed: the model in one int64 and one float64 array,
the obstacles in one float64 array, the scratch in one float64 array (a numba function takes
four arrays from Python in well under a microsecond, a tuple of two dozen does not), and the
views the kernels (mpnet.envs.sphere_kernels) unpack them into."""

from __future__ import annotations

from numba import njit

QUEUE = 1 << 14  # motion intervals pending at once; a motion that needs more is called blocked
HEAD = 7  # mi starts with F, L, G, S, P, D, first
# The model tuple's fields, in unpack's order.
PARENT, ORIGIN, KIND, AXIS, COORD = 0, 1, 2, 3, 4
LINK_FRAME, LINK_G0, LINK_G1, GROUP_FRAME, GROUP_S0, GROUP_S1 = 5, 6, 7, 8, 9, 10
LOCAL, RADIUS, BLOCAL, BRADIUS, GLOCAL, GRADIUS = 11, 12, 13, 14, 15, 16
PAIR_A, PAIR_B, FIRST, LEVER, LLEVER, GLEVER, PAIR_J0 = 17, 18, 19, 20, 21, 22, 23


@njit(cache=True)
def unpack(mi, mf):
    """The model's arrays as views of its two packed arrays (one int64, one float64: two
    arguments dispatch from Python in well under a microsecond, a tuple of 24 does not)."""
    F, L, G, S, P, D, first = mi[0], mi[1], mi[2], mi[3], mi[4], mi[5], mi[6]
    o = HEAD
    parent, kind, coord = mi[o : o + F], mi[o + F : o + 2 * F], mi[o + 2 * F : o + 3 * F]
    o += 3 * F
    link_frame, link_g0, link_g1 = mi[o : o + L], mi[o + L : o + 2 * L], mi[o + 2 * L : o + 3 * L]
    o += 3 * L
    group_frame, group_s0, group_s1 = mi[o : o + G], mi[o + G : o + 2 * G], mi[o + 2 * G : o + 3 * G]
    o += 3 * G
    pair_a, pair_b, pair_j0 = mi[o : o + P], mi[o + P : o + 2 * P], mi[o + 2 * P : o + 3 * P]
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
    glocal = mf[o : o + 3 * G].reshape((G, 3))
    o += 3 * G
    gradius = mf[o : o + G]
    o += G
    lever = mf[o : o + S * D].reshape((S, D))
    o += S * D
    llever = mf[o : o + L * D].reshape((L, D))
    o += L * D
    glever = mf[o : o + G * D].reshape((G, D))
    return (
        parent,
        origin,
        kind,
        axis,
        coord,
        link_frame,
        link_g0,
        link_g1,
        group_frame,
        group_s0,
        group_s1,
        local,
        radius,
        blocal,
        bradius,
        glocal,
        gradius,
        pair_a,
        pair_b,
        first,
        lever,
        llever,
        glever,
        pair_j0,
    )


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


# The scratch tuple's fields, in unpack_buffers' order.
POSE, CENTRES, LCENTRES, GCENTRES, LPLACED, GPLACED, LEXTRA, GEXTRA, LB, GB = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9
QVEC, DQ, AXPOINT, AXDIR, PRIS, TOP, T0S, T1S, PG = 10, 11, 12, 13, 14, 15, 16, 17, 18


@njit(cache=True)
def unpack_buffers(mi, buf):
    """Scratch views: poses (F + 1, 3, 4); sphere, link and group centres; link and group
    placed flags; link and group growth and second-order terms; a joint vector and the
    motion's joint steps; the joints' axes (points, directions, prismatic flags); the
    largest growth; the motion queue's interval ends."""
    F, L, G, S, D = mi[0], mi[1], mi[2], mi[3], mi[5]
    o = 12 * (F + 1)
    pose = buf[:o].reshape((F + 1, 3, 4))
    centres = buf[o : o + 3 * S].reshape((S, 3))
    o += 3 * S
    lcentres = buf[o : o + 3 * L].reshape((L, 3))
    o += 3 * L
    gcentres = buf[o : o + 3 * G].reshape((G, 3))
    o += 3 * G
    lplaced, gplaced = buf[o : o + L], buf[o + L : o + L + G]
    o += L + G
    lextra, gextra = buf[o : o + L], buf[o + L : o + L + G]
    o += L + G
    lb, gb = buf[o : o + L], buf[o + L : o + L + G]
    o += L + G
    q, dq = buf[o : o + D], buf[o + D : o + 2 * D]
    o += 2 * D
    ap = buf[o : o + 3 * D].reshape((D, 3))
    o += 3 * D
    au = buf[o : o + 3 * D].reshape((D, 3))
    o += 3 * D
    pris, top = buf[o : o + D], buf[o + D : o + D + 1]
    o += D + 1
    t0s, t1s = buf[o : o + QUEUE], buf[o + QUEUE : o + 2 * QUEUE]
    o += 2 * QUEUE
    pg = buf[o : o + G]
    return (
        pose,
        centres,
        lcentres,
        gcentres,
        lplaced,
        gplaced,
        lextra,
        gextra,
        lb,
        gb,
        q,
        dq,
        ap,
        au,
        pris,
        top,
        t0s,
        t1s,
        pg,
    )


def buffer_size(F: int, L: int, G: int, S: int, D: int) -> int:
    return 12 * (F + 1) + 3 * (S + L + G) + 3 * (L + G) + 9 * D + 1 + 2 * QUEUE + G
