"""MPNet's planning loop compiled (numba): NeuralPlanner (Algorithm 2) with Pnet's step
inside, steerTo, lazy states contraction and the feasibility check, on a motion memo, with
the env's checks called without Python in between.

Everything decides as the numpy planner (mpnet.planners.neural) does, call for call: the
same checks in the same order through the same memo (a motion's verdict is remembered the
first time it is computed, by the one-motion or the batch test, as MotionMemo does), so the
same paths and the same check counts.

An env's checks come as one tuple of arrays (`env`), the checker's compiled form
(`CollisionChecker.compiled_env`); the checks and the state space's wrap on it are
mpnet.envs.checkers.compiled_env's, which picks each robot kind's kernels: nothing here knows a robot.

The memo is an open-addressing table (keys (cap, 2d), verdicts int8: -1 empty, 0, 1) keyed
by the motion's coordinates compared as floats (so -0.0 is 0.0, as in a dict of tuples).
"""

from __future__ import annotations

import numpy as np

from mpnet.envs.checkers.compiled_env import (
    bounded_dims,
    canonical,
    motion_free,
    motions_free,
    state_free,
    wrap_difference,
)
from mpnet.jit import njit
from mpnet.models.pnet_kernel import pnet_rows, pnet_step
from mpnet.planners.base import RANDOM_TRIES

PNET, RANDOM, RANDOM_ANY, STRAIGHT = 0, 1, 2, 3  # mpnet.planners.neural.PROPOSALS, in order
MEMO_BITS = 15  # 32768 motions per query; past 70% full, new verdicts are not remembered


def new_memo(state_dim: int, bits: int = MEMO_BITS):
    return np.empty((1 << bits, 2 * state_dim)), np.full(1 << bits, -1, np.int8), np.zeros(1, np.int64)


@njit(cache=True)
def _hash(a, b):
    h = np.uint64(14695981039346656037)
    for x in (a, b):
        for k in range(x.shape[0]):
            v = x[k] + 0.0  # -0.0 -> 0.0: equal floats, equal keys
            w = np.array([v]).view(np.uint64)[0]
            h = (h ^ w) * np.uint64(1099511628211)
            h ^= h >> np.uint64(29)
    return h


@njit(cache=True)
def _find(memo, a, b):
    """(verdict or -1, the slot it is in or would go in)."""
    keys, verdicts, _ = memo
    mask = verdicts.shape[0] - 1
    d = a.shape[0]
    slot = np.int64(_hash(a, b) & np.uint64(mask))
    while verdicts[slot] != -1:
        same = True
        for k in range(d):
            if keys[slot, k] != a[k] or keys[slot, d + k] != b[k]:
                same = False
                break
        if same:
            return verdicts[slot], slot
        slot = (slot + 1) & mask
    return -1, slot


@njit(cache=True)
def _remember(memo, slot, a, b, ok):
    keys, verdicts, used = memo
    if used[0] * 10 >= verdicts.shape[0] * 7:
        return
    d = a.shape[0]
    for k in range(d):
        keys[slot, k] = a[k]
        keys[slot, d + k] = b[k]
    verdicts[slot] = 1 if ok else 0
    used[0] += 1


@njit(cache=True)
def is_valid(env, counts, q):
    counts[0] += 1
    return state_free(env, counts, q)


@njit(cache=True)
def motion_valid(env, memo, counts, a, b):
    """MotionMemo.motion_valid: a remembered verdict, else the one-motion test (counted)."""
    v, slot = _find(memo, a, b)
    if v != -1:
        return v == 1
    counts[1] += 1
    ok = motion_free(env, counts, a, b)
    _remember(memo, slot, a, b, ok)
    return ok


@njit(cache=True)
def motions_valid(env, memo, counts, A, B, out):
    """MotionMemo.motions_valid: remembered verdicts, the rest by one batch test (counted)."""
    n, d = A.shape
    todo = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        v, _ = _find(memo, A[i], B[i])
        out[i] = v == 1
        if v == -1:
            todo[m] = i
            m += 1
    if m == 0:
        return
    TA, TB, fresh = np.empty((m, d)), np.empty((m, d)), np.empty(m, np.bool_)
    for r in range(m):
        TA[r], TB[r] = A[todo[r]], B[todo[r]]
    counts[1] += m
    motions_free(env, counts, TA, TB, fresh)
    for r in range(m):
        i = todo[r]
        out[i] = fresh[r]
        v, slot = _find(memo, A[i], B[i])
        if v == -1:
            _remember(memo, slot, A[i], B[i], fresh[r])


@njit(cache=True)
def is_feasible(env, memo, counts, path):
    """mpnet.motion.is_feasible on the memo."""
    n = path.shape[0]
    if n == 0:
        return False
    if n == 1:
        return is_valid(env, counts, path[0])
    out = np.empty(n - 1, np.bool_)
    motions_valid(env, memo, counts, path[:-1], path[1:], out)
    return out.all()


@njit(cache=True)
def contract(env, memo, counts, path):
    """mpnet.motion.lazy_states_contraction (continuous steerTo): the indices of the states kept."""
    n = path.shape[0]
    if n <= 2:
        return np.arange(n)
    keep = np.empty(n, np.int64)
    keep[0] = 0
    m, i = 1, 0
    while i < n - 1:
        nxt = i + 1
        for j in range(n - 1, i + 1, -1):
            if motion_valid(env, memo, counts, path[i], path[j]):
                nxt = j
                break
        keep[m] = nxt
        m += 1
        i = nxt
    return keep[:m]


@njit(cache=True)
def _sample(rng, lower, upper, q):
    """StateSpace.sample: rng.uniform(lower, upper), one draw per coordinate in order."""
    for k in range(q.shape[0]):
        q[k] = rng.uniform(lower[k], upper[k])


@njit(cache=True)
def _settle(env, prop, new):
    """A Pnet proposal into canonical coordinates: wrapped, or clipped into the bounds (prop's clip)."""
    _, clip, _, lower, upper, _ = prop
    canonical(env, new)
    if clip:
        for k in range(bounded_dims(env, new.shape[0])):
            new[k] = min(max(new[k], lower[k]), upper[k])


@njit(cache=True)
def _propose(env, counts, prop, z, x, target, net, rng, dropout, buf, new):
    """MPNetPlanner.propose into `new`: Pnet's step, wrapped or clipped into the bounds (clip),
    or an ablation's proposal (mpnet.planners.neural: random_valid_state, space.sample,
    straight_step)."""
    kind, clip, length, lower, upper, half = prop
    if kind == PNET:
        (plain, dropped, biases, alphas, p, mask_scale, offsets, shift2, inv2, out_scale, out_off, bounded,
         prelu_max, lay) = net  # fmt: skip
        pnet_step(
            z, x, target, plain, dropped, biases, alphas, p, mask_scale, offsets, shift2, inv2, out_scale, out_off,
            bounded, prelu_max, lay, rng, dropout, buf, new,
        )  # fmt: skip
        _settle(env, prop, new)
    elif kind == RANDOM:
        for _ in range(RANDOM_TRIES):
            _sample(rng, lower, upper, new)
            if is_valid(env, counts, new):
                break
    elif kind == RANDOM_ANY:
        _sample(rng, lower, upper, new)
    else:  # STRAIGHT
        d = target - x
        wrap_difference(env, d)
        v = d / half
        norm = np.sqrt(np.dot(v, v))
        if norm <= length:
            new[:] = x + d
        else:
            new[:] = x + d * (length / norm)
        canonical(env, new)


@njit(cache=True)
def neural_planner(z, start, goal, max_steps, precheck, env, memo, counts, prop, net, rng, dropout, buf, trees, trace):
    """Algorithm 2 (MPNetPlanner.neural_planner): grow a path from each end by Pnet (or the
    ablation's proposals, `prop`: kind, clip, straight step, the space's lower, upper and
    half-widths), alternating, until steerTo connects their tips. trees: (2, max_steps + 1, d)
    scratch; trace: (max_steps, 2, d), each step's tree end and proposal. Returns (connected,
    states of the start's tree, of the goal's tree, steps taken); connected: the path is start's
    tree + goal's reversed."""
    trees[0, 0], trees[1, 0] = start, goal
    n = np.zeros(2, np.int64)
    n[0], n[1] = 1, 1
    if precheck and motion_valid(env, memo, counts, start, goal):
        return True, n[0], n[1], 0
    a = 0  # the tree grown this step: 0 the start's, 1 the goal's
    for s in range(max_steps):
        b = 1 - a
        x, target = trees[a, n[a] - 1], trees[b, n[b] - 1]
        new = trees[a, n[a]]
        _propose(env, counts, prop, z, x, target, net, rng, dropout, buf, new)
        trace[s, 0], trace[s, 1] = x, new
        n[a] += 1
        if motion_valid(env, memo, counts, new, trees[b, n[b] - 1]):
            return True, n[0], n[1], s + 1
        a = b
    return False, n[0], n[1], max_steps


@njit(cache=True)
def lockstep(z, starts, goals, max_steps, precheck, env, memos, counts, prop, net, rng, dropout, buf, scratch,
             live, trees, n, steps, connected, trace):  # fmt: skip
    """Batched planning's first NeuralPlanner runs (mpnet.planners.compiled.batched): query b grows
    trees[b] from starts[b] and goals[b] as neural_planner does, all live queries one step at a
    time, their proposals from one pnet_rows call per step. memos: (keys, verdicts, used) with a
    leading query axis; counts (B, 3); scratch: (X, T, Y) of (B, d); live: the queries to run
    (endpoints valid); out: n (B, 2) tree sizes, steps (B,), connected (B,), trace (B, S, 2, d)."""
    (plain, dropped, biases, alphas, p, mask_scale, offsets, shift2, inv2, out_scale, out_off, bounded, prelu_max,
     lay) = net  # fmt: skip
    keys, verdicts, used = memos
    X, T, Y = scratch
    B = starts.shape[0]
    grow = np.zeros(B, np.int64)
    rows = np.empty(B, np.int64)
    for b in range(B):
        trees[b, 0, 0], trees[b, 1, 0] = starts[b], goals[b]
        n[b, 0], n[b, 1] = 1, 1
        steps[b], connected[b] = 0, False
        if (
            live[b]
            and precheck
            and motion_valid(env, (keys[b], verdicts[b], used[b : b + 1]), counts[b], starts[b], goals[b])
        ):
            connected[b], live[b] = True, False
    for _ in range(max_steps):
        m = 0
        for b in range(B):
            if live[b]:
                g = grow[b]
                X[m], T[m] = trees[b, g, n[b, g] - 1], trees[b, 1 - g, n[b, 1 - g] - 1]
                rows[m] = b
                m += 1
        if m == 0:
            break
        pnet_rows(
            z, X, T, m, plain, dropped, biases, alphas, p, mask_scale, offsets, shift2, inv2, out_scale, out_off,
            bounded, prelu_max, lay, rng, dropout, buf, Y,
        )  # fmt: skip
        for r in range(m):
            b = rows[r]
            g = grow[b]
            new = trees[b, g, n[b, g]]
            new[:] = Y[r]
            _settle(env, prop, new)
            trace[b, steps[b], 0], trace[b, steps[b], 1] = X[r], new
            steps[b] += 1
            n[b, g] += 1
            if motion_valid(
                env, (keys[b], verdicts[b], used[b : b + 1]), counts[b], new, trees[b, 1 - g, n[b, 1 - g] - 1]
            ):
                connected[b], live[b] = True, False
            else:
                grow[b] = 1 - g
