"""Motion primitives shared by every planner, and the fine re-check that decides success."""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from mpnet.envs.collision import CollisionChecker, make_checker
from mpnet.envs.workspace import EnvSpec, Workspace, wrap_angle


def steer_to(checker: CollisionChecker, a, b, step: float | None = None) -> bool:
    """Is the straight motion a -> b free?

    step None: the continuous check (exact for boxes). A step: the T-RO code's discretised
    steerTo, states no farther apart than `step` (a coarse step can cut a corner, which is
    why MPNet's feasibility check stays continuous).
    """
    if step is None:
        return checker.motion_valid(a, b)
    return bool(checker.valid_states(interpolate(checker.spec, a, b, step)).all())


def is_feasible(checker: CollisionChecker, path: Sequence) -> bool:
    """Every state and every segment of the path is free."""
    if len(path) == 0:
        return False
    if len(path) == 1:
        return bool(checker.is_valid(path[0]))
    p = np.asarray(path, float)
    return bool(checker.valid_motions(p[:-1], p[1:]).all())


def lazy_states_contraction(checker: CollisionChecker, path: Sequence, step: float | None = None) -> list:
    """Greedy LSC: from each kept state, jump to the farthest state steer_to connects it to."""
    path = list(path)
    if len(path) <= 2:
        return path
    out = [path[0]]
    i = 0
    while i < len(path) - 1:
        nxt = i + 1
        for j in range(len(path) - 1, i + 1, -1):
            if steer_to(checker, path[i], path[j], step):
                nxt = j
                break
        out.append(path[nxt])
        i = nxt
    return out


def path_cost(spec: EnvSpec, path: Sequence) -> float:
    """Length of the path under the env's metric (EnvSpec.distance)."""
    return float(sum(spec.distance(a, b) for a, b in zip(path[:-1], path[1:])))


def interpolate(spec: EnvSpec, a, b, step: float) -> np.ndarray:
    """States along a -> b no farther apart than `step` in workspace units.

    For the rigid body the step bounds the motion of any point of the body: position
    change, or angle change times the half-diagonal, whichever is larger.
    """
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    d = b - a
    if spec.is_se2:
        d[2] = wrap_angle(d[2])
        radius = math.hypot(*(s / 2 for s in spec.robot_size))
        length = max(math.hypot(d[0], d[1]), abs(d[2]) * radius)
    else:
        length = float(np.linalg.norm(d))
    n = int(math.ceil(length / step)) + 1
    out = a + np.linspace(0.0, 1.0, n + 1)[:, None] * d
    k = 2 if spec.is_se2 else len(b)
    out[-1, :k] = b[:k]  # a + 1.0 * d can round past b: a state on the bound must stay on it
    return out


def interpolate_path(spec: EnvSpec, path: np.ndarray, step: float) -> np.ndarray:
    """Every segment of the path sampled as `interpolate` does, in one vectorised pass."""
    a, d = path[:-1], np.diff(path, axis=0)
    if spec.is_se2:
        d[:, 2] = wrap_angle(d[:, 2])
        radius = math.hypot(*(s / 2 for s in spec.robot_size))
        length = np.maximum(np.hypot(d[:, 0], d[:, 1]), np.abs(d[:, 2]) * radius)
    else:
        length = np.linalg.norm(d, axis=1)
    n = np.ceil(length / step).astype(int) + 2  # samples per segment, both ends included
    seg = np.repeat(np.arange(len(d)), n)
    first = np.cumsum(n) - n
    t = (np.arange(n.sum()) - np.repeat(first, n)) / np.repeat(n - 1, n)
    out = a[seg] + t[:, None] * d[seg]
    last = np.cumsum(n) - 1
    k = 2 if spec.is_se2 else path.shape[1]
    out[last, :k] = path[1:, :k]  # as in interpolate: each segment ends exactly at its state
    return out


def verify_path(spec: EnvSpec, ws: Workspace, path, start, goal, step: float | None = None) -> str | None:
    """The independent fine re-check (DESIGN §5): None when the path is a success, else why not.

    Samples every segment at `step` (the env's validation step) against the exact closed
    boxes; it never uses the planners' continuous motion test.
    """
    step = step or spec.validation_step
    if path is None or len(path) < 2:
        return "no_path"
    p = np.asarray(path, float)
    if p.ndim != 2 or p.shape[1] != spec.state_dim or not np.all(np.isfinite(p)):
        return "malformed_path"
    ends = np.abs(p[[0, -1]] - np.array([start, goal], float))
    if not ends.max() <= 1e-6:
        return "wrong_endpoints"
    samples = interpolate_path(spec, p, step)
    ok = make_checker(spec, ws, margin=0.0)._states_free(samples)
    if ok.all():
        return None
    bad = samples[~ok][0]
    return "out_of_bounds" if not spec.in_bounds(bad) else "collision"
