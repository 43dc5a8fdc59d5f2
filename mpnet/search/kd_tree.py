"""Exact nearest neighbours in a growing RRT tree (numba): a k-d tree over the tree's states,
built as they are added, searched branch and bound.

Why: a linear scan costs about 2 ns a state, and RRT-Connect scans both trees every round;
on a hard arm query (thousands of rounds, trees of thousands of states: the expert's hardest
runs, which are most of its time) the scan was about half of the search. The tree answers
what the scan answers, bit for bit: a state's squared distance is summed over the
coordinates in the scan's order, ties go to the lowest index, and a subtree is skipped only
when the distance along its splitting coordinate alone, which every state in it reaches or
exceeds (rounding is monotone), is strictly above the best so far. For all-Euclidean spaces
(the arm's joints); a space with a wrapped angle keeps the scan.

Layout, per RRT tree t (the search's arrays, kept by its caller): kd nodes in insertion
order, node 0 the root. An inner node splits at `vals[t, k]` along coordinate `dims[t, k]`
(states below go to kids[t, k, 0], the rest to kids[t, k, 1]); a leaf (kids -1) holds up to
LEAF state indices in items[t, k]. A full leaf splits at its median along its widest
coordinate. meta[t] = (kd nodes used, off): `off` is set when the kd nodes run out or a
leaf's states are all equal, and the caller then scans (never a wrong answer, only a
slower one).
"""

from __future__ import annotations

import numpy as np

from mpnet.jit import njit

LEAF = 32  # states a leaf holds before it splits
DEPTH = 64  # the search's stack: a deeper tree (never seen: median splits) is scanned instead
USED, OFF = 0, 1  # meta's columns


def kd_arrays(cap: int) -> tuple:
    """The k-d trees' arrays for two RRT trees of up to `cap` states each: dims, vals, kids,
    items, counts, meta, and the search's stack (nodes, bounds) and a leaf split's scratch."""
    m = cap // 4 + 8  # median splits: a leaf holds >= LEAF / 2 states, so about cap / 8 nodes are used
    return (
        np.zeros((2, m), np.int64),
        np.zeros((2, m)),
        np.full((2, m, 2), -1, np.int64),
        np.zeros((2, m, LEAF), np.int64),
        np.zeros((2, m), np.int64),
        np.zeros((2, 2), np.int64),
        np.zeros(DEPTH, np.int64),
        np.zeros(DEPTH),
        np.zeros(LEAF),
    )


def kd_grown(kd: tuple, into: tuple) -> tuple:
    """`into` (kd_arrays of a larger capacity) holding every kd node of kd: the search's arrays doubled."""
    m = kd[0].shape[1]
    for old, new in zip(kd[:5], into[:5]):
        new[:, :m] = old
    into[5][:] = kd[5]
    return into


@njit(cache=True, borrowed=True)
def kd_reset(kd, t):
    """Tree t's k-d tree empty: one leaf, the root, holding nothing."""
    kd[2][t, 0, 0], kd[2][t, 0, 1] = -1, -1
    kd[4][t, 0] = 0
    kd[5][t, USED], kd[5][t, OFF] = 1, 0


@njit(cache=True, borrowed=True)
def _split(kd, t, leaf, cols):
    """Leaf `leaf` (full) split at the median of its widest coordinate into two new leaves; the
    tree turned off where it cannot be (its states all equal, or no kd nodes left)."""
    dims, vals, kids, items, counts, meta, _, _, scratch = kd
    used = meta[t, USED]
    if used + 2 > dims.shape[1]:
        meta[t, OFF] = 1
        return
    n = counts[t, leaf]
    d, widest = 0, -1.0
    for k in range(cols.shape[1]):
        lo, hi = np.inf, -np.inf
        for j in range(n):
            x = cols[t, k, items[t, leaf, j]]
            lo, hi = min(lo, x), max(hi, x)
        if hi - lo > widest:
            d, widest = k, hi - lo
    for j in range(n):  # the widest coordinate's values, sorted (insertion sort: LEAF values)
        x = cols[t, d, items[t, leaf, j]]
        i = j
        while i > 0 and scratch[i - 1] > x:
            scratch[i] = scratch[i - 1]
            i -= 1
        scratch[i] = x
    cut = scratch[n // 2]
    if cut == scratch[0]:  # half or more equal the least: cut above them
        i = n // 2
        while i < n and scratch[i] == cut:
            i += 1
        if i == n:  # every state equal along its widest coordinate: all equal
            meta[t, OFF] = 1
            return
        cut = scratch[i]
    lo, hi = used, used + 1
    counts[t, lo], counts[t, hi] = 0, 0
    for j in range(n):
        s = items[t, leaf, j]
        side = lo if cols[t, d, s] < cut else hi
        items[t, side, counts[t, side]] = s
        counts[t, side] += 1
    kids[t, lo, 0], kids[t, lo, 1], kids[t, hi, 0], kids[t, hi, 1] = -1, -1, -1, -1
    dims[t, leaf], vals[t, leaf] = d, cut
    kids[t, leaf, 0], kids[t, leaf, 1] = lo, hi
    meta[t, USED] = used + 2


@njit(cache=True, borrowed=True)
def kd_insert(kd, t, s, cols):
    """State s of tree t (its coordinates in cols[t, :, s]) added to its k-d tree."""
    dims, vals, kids, items, counts, meta = kd[0], kd[1], kd[2], kd[3], kd[4], kd[5]
    if meta[t, OFF]:
        return
    k = 0
    while kids[t, k, 0] >= 0:
        k = kids[t, k, 0] if cols[t, dims[t, k], s] < vals[t, k] else kids[t, k, 1]
    c = counts[t, k]
    items[t, k, c] = s
    counts[t, k] = c + 1
    if c + 1 == LEAF:
        _split(kd, t, k, cols)


@njit(cache=True, borrowed=True)
def kd_nearest(kd, t, cols, q):
    """The index of tree t's state nearest q (squared Euclidean distance, summed in coordinate
    order; the lowest index of equals), or -1 where the k-d tree cannot answer (off, or its
    stack too shallow): the caller then scans."""
    dims, vals, kids, items, counts, meta, stack, bounds = kd[0], kd[1], kd[2], kd[3], kd[4], kd[5], kd[6], kd[7]
    if meta[t, OFF]:
        return -1
    D = q.shape[0]
    best, bi = np.inf, -1
    top = 0
    stack[0], bounds[0] = 0, 0.0
    while top >= 0:
        k, bound = stack[top], bounds[top]
        top -= 1
        if bound > best:
            continue
        if kids[t, k, 0] < 0:
            for j in range(counts[t, k]):
                s = items[t, k, j]
                dist = 0.0
                for x in range(D):
                    v = cols[t, x, s] - q[x]
                    dist += v * v
                if dist < best or (dist == best and s < bi):
                    best, bi = dist, s
            continue
        if top + 2 >= stack.shape[0]:
            return -1
        gap = q[dims[t, k]] - vals[t, k]
        near, far = (kids[t, k, 0], kids[t, k, 1]) if gap < 0.0 else (kids[t, k, 1], kids[t, k, 0])
        top += 1
        stack[top], bounds[top] = far, gap * gap
        top += 1
        stack[top], bounds[top] = near, bound
    return bi
