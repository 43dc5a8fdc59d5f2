"""RRT-Connect (Kuffner and LaValle 2000) compiled (numba), as OMPL's `RRTConnect` runs it,
on the env's compiled checks (mpnet.envs.checkers.compiled_env): no Python between a sample
and its checks, so the planner pays what MPNet's compiled loop pays per check.

OMPL's algorithm, step for step: the trees take turns; a uniform sample is grown toward
from the turn's tree (its nearest state, moved at most `reach` toward the sample; the start
tree checks the motion nearest -> new, the goal tree the new state and then new -> nearest;
a tree's states are known free, so a motion's check does not test them first: the roots
are checked once);
if that tree moved, the other tree is grown toward the state just added until it reaches it
(connected) or is trapped. Nearest neighbours by a linear scan of a small tree, and of a tree
of KD_MIN states or more by its k-d tree (mpnet.search.kd_tree; OMPL: GNAT), which finds the
node the scan finds: the same search either way, the hard queries' big trees cheaper.

A search runs in slices (`grow`, at most `iterations` samples a call) so that the caller
checks the clock between calls (numba has no clock); the trees and the turn live in the
caller's arrays, so a slice picks up where the last stopped.
"""

from __future__ import annotations

import math

import numpy as np

from mpnet.envs.checkers.compiled_env import bounded_dims, canonical, motion_free_known, state_free, wrap_difference
from mpnet.jit import njit
from mpnet.search.kd_tree import kd_insert, kd_nearest, kd_reset

KD_MIN = 128  # a tree of at least this many states is searched by its k-d tree (kd_tree), a smaller one scanned

TRAPPED, ADVANCED, REACHED = 0, 1, 2
# grow's outcome
RUNNING, CONNECTED, FULL = 0, 1, 2
# state: the trees' sizes, whose turn it is (0 the start tree), the connection's two nodes, the rounds run
N0, N1, TURN, JOIN0, JOIN1, ROUNDS = 0, 1, 2, 3, 4, 5


def new_state() -> np.ndarray:
    """A search's state before its first round: one root in each tree, the start tree's turn."""
    return np.array([1, 1, 0, -1, -1, 0], np.int64)


@njit(cache=True, borrowed=True)
def uniform(rng, lo, hi):
    """A uniform draw in [lo, hi) from a splitmix64 stream (rng: its one uint64 of state). A
    Generator argument costs ~30 us to hand to numba per call, more than a 2-D query's search."""
    rng[0] += np.uint64(0x9E3779B97F4A7C15)
    z = rng[0]
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z ^= z >> np.uint64(31)
    return lo + (hi - lo) * (np.float64(z >> np.uint64(11)) * (1.0 / 9007199254740992.0))


@njit(cache=True, borrowed=True)
def distance(env, weights, a, b, d):
    """The space's metric (mpnet.envs.spaces): Euclidean over the bounded coordinates, plus
    weight x |difference| for each wrapped one (SE2's angle, along the shorter arc). d: scratch,
    left holding b - a the shorter way."""
    for k in range(d.shape[0]):
        d[k] = b[k] - a[k]
    wrap_difference(env, d)
    kb = bounded_dims(env, d.shape[0])
    s = 0.0
    for k in range(kb):
        s += d[k] * d[k]
    out = math.sqrt(s)
    for k in range(kb, d.shape[0]):
        out += weights[k] * abs(d[k])
    return out


@njit(cache=True, borrowed=True)
def nearest(env, weights, nodes, cols, n, q, scratch, dist):
    """The index of the node (of the first n) nearest q, the first of equals (scratch:
    distance's). cols: the nodes column by column (cols[k, i] = nodes[i, k]), so that an
    all-Euclidean space's squared distances are summed a coordinate at a time over every node
    (a loop the compiler vectorises; node by node, a tree of thousands of states cost more to
    scan than its collision checks), into dist, in the same order as node by node: the same
    sums, so the same node."""
    d = q.shape[0]
    if bounded_dims(env, d) == d:  # all Euclidean: squared distances compare the same, no root
        for i in range(n):
            dist[i] = 0.0
        for k in range(d):
            qk = q[k]
            row = cols[k]
            for i in range(n):
                t = row[i] - qk
                dist[i] += t * t
        best, bi = np.inf, 0
        for i in range(n):
            if dist[i] < best:
                best, bi = dist[i], i
        return bi
    best, bi = np.inf, 0
    for i in range(n):
        s = distance(env, weights, nodes[i], q, scratch)
        if s < best:
            best, bi = s, i
    return bi


@njit(cache=True)
def roots_free(env, counts, start, goal):
    """Are both roots free? Checked once a search (counted as state checks): a motion's
    check skips a tree's state (motion_free_known), and without its early exit a search
    from a blocked root would spend its whole budget finding nothing."""
    for q in (start, goal):
        counts[0] += 1
        if not state_free(env, counts, q):
            return False
    return True


@njit(cache=True, borrowed=True)
def _extend(env, counts, weights, reach, nodes, parents, cols, dist, kd, state, t, target, d):
    """OMPL's growTree: tree t's nearest node moved toward target by at most `reach`, added
    when its motion is free. TRAPPED, ADVANCED (moved, target not reached) or REACHED. d,
    dist: scratch; cols: the trees column by column (grow); kd: their k-d trees (grow)."""
    n = state[t]
    euclidean = bounded_dims(env, d.shape[0]) == d.shape[0]
    i = kd_nearest(kd, t, cols, target) if euclidean and n >= KD_MIN else -1
    if i < 0:
        i = nearest(env, weights, nodes[t], cols[t], n, target, d, dist)
    near = nodes[t, i]
    new = nodes[t, n]
    dist = distance(env, weights, near, target, d)  # d: target - near, the shorter way
    reached = True
    if dist > reach:
        f = reach / dist
        for k in range(d.shape[0]):
            new[k] = near[k] + f * d[k]
        canonical(env, new)
        same = True
        for k in range(d.shape[0]):
            if new[k] != near[k]:
                same = False
                break
        if same:
            return TRAPPED
        reached = False
    else:
        for k in range(new.shape[0]):  # a loop: a slice copy may allocate (arrays could overlap)
            new[k] = target[k]
    # a tree's states are free: a motion from one is not checked there again (the same answer)
    if t == 0:
        counts[1] += 1
        ok = motion_free_known(env, counts, near, new, 1)
    else:  # the goal tree: the new state, then the motion toward its tree (OMPL's order)
        counts[0] += 1
        ok = state_free(env, counts, new)
        if ok:
            counts[1] += 1
            ok = motion_free_known(env, counts, new, near, 2)
    if not ok:
        return TRAPPED
    parents[t, n] = i
    for k in range(new.shape[0]):
        cols[t, k, n] = new[k]
    if euclidean:
        kd_insert(kd, t, n, cols)
    state[t] = n + 1
    return REACHED if reached else ADVANCED


@njit(cache=True, borrowed=True)
def grow(
    env, counts, weights, lower, upper, reach, rng, nodes, parents, cols, dist, kd, state, iterations, room, sample, d
):  # noqa: E501
    """Up to `iterations` rounds of RRT-Connect on the trees (nodes (2, cap, d), parents
    (2, cap), cols (2, d, cap): the nodes column by column, for nearest; kd: their k-d trees
    (kd_tree.kd_arrays), started here at the first round; state: see N0..JOIN1; each tree's
    root placed by the caller in nodes and cols; sample, d: scratch of a state's length; dist:
    scratch of cap). Returns
    CONNECTED (state[JOIN0], state[JOIN1]: the start tree's and the goal tree's nodes that
    meet, the same state: the connecting tree's last step reached its target exactly),
    RUNNING (iterations spent) or FULL (a tree within `room` nodes of its capacity: the
    caller grows the arrays). state[ROUNDS] counts the rounds run."""
    cap = nodes.shape[1]
    if state[ROUNDS] == 0:
        for t in range(2):
            kd_reset(kd, t)
            kd_insert(kd, t, 0, cols)
    for _ in range(iterations):
        if state[N0] + room >= cap or state[N1] + room >= cap:
            return FULL
        t = state[TURN]
        state[TURN] = 1 - t
        state[ROUNDS] += 1
        for k in range(sample.shape[0]):
            sample[k] = uniform(rng, lower[k], upper[k])
        if _extend(env, counts, weights, reach, nodes, parents, cols, dist, kd, state, t, sample, d) == TRAPPED:
            continue
        added = state[t] - 1
        for k in range(sample.shape[0]):  # the other tree's target: the state just added (the sample is spent)
            sample[k] = nodes[t, added, k]
        o = 1 - t
        g = _extend(env, counts, weights, reach, nodes, parents, cols, dist, kd, state, o, sample, d)
        while g == ADVANCED:
            g = _extend(env, counts, weights, reach, nodes, parents, cols, dist, kd, state, o, sample, d)
        if g == REACHED:
            if t == 0:
                state[JOIN0], state[JOIN1] = added, state[o] - 1
            else:
                state[JOIN0], state[JOIN1] = state[o] - 1, added
            return CONNECTED
    return RUNNING


@njit(cache=True)
def solution(nodes, parents, state):
    """The path of a connection: the start tree's root to its joining node, then the goal
    tree's joining node's parent to its root (the joining nodes are the same state)."""
    d = nodes.shape[2]
    a, b = state[JOIN0], state[JOIN1]
    na, nb = 1, 1
    i = a
    while i != 0:
        i = parents[0, i]
        na += 1
    i = b
    while i != 0:
        i = parents[1, i]
        nb += 1
    out = np.empty((na + nb, d))
    i = a
    for r in range(na - 1, -1, -1):
        out[r] = nodes[0, i]
        i = parents[0, i]
    i = b
    for r in range(na, na + nb):
        out[r] = nodes[1, i]
        i = parents[1, i]
    # the two joining nodes are one state (a REACHED step copies its target): kept once, the
    # start tree's; the goal tree's edge from it to its parent is the motion that was checked
    keep = np.ones(na + nb, np.bool_)
    keep[na] = False
    return out[keep]
