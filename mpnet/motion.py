"""Motion primitives shared by every planner, and the fine re-check that decides success."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mpnet.envs.checkers.collision import CollisionChecker
from mpnet.envs.spec import EnvSpec
from mpnet.envs.workspace import Workspace


class MotionMemo:
    """A checker that remembers each straight motion's verdict, for one query.

    MPNet tests the same segments again and again: the feasibility check re-tests the jumps
    lazy states contraction just verified, and each replanning round contracts and checks a
    path that is mostly the last one. A verdict never changes within a workspace, so the
    decisions (and paths) are the same as without the memo; only checks that were already
    made are not made (nor counted) again. Everything else goes to the wrapped checker."""

    def __init__(self, checker: CollisionChecker):
        self.checker = checker
        self._seen: dict[tuple, bool] = {}

    def __getattr__(self, name):
        return getattr(self.checker, name)

    def motion_valid(self, a, b) -> bool:
        key = (*a, *b)
        ok = self._seen.get(key)
        if ok is None:
            ok = self._seen[key] = bool(self.checker.motion_valid(a, b))
        return ok

    def motions_valid(self, a, b) -> np.ndarray:
        a = np.asarray(a, float).reshape(-1, self.checker.spec.state_dim)
        b = np.asarray(b, float).reshape(-1, self.checker.spec.state_dim)
        keys = [tuple(r) for r in np.hstack((a, b)).tolist()]
        out = np.array([self._seen.get(k, False) for k in keys], bool)
        todo = [i for i, k in enumerate(keys) if k not in self._seen]
        if todo:
            fresh = self.checker.motions_valid(a[todo], b[todo])
            out[todo] = fresh
            self._seen.update((keys[i], bool(v)) for i, v in zip(todo, fresh))
        return out


def steer_to(checker: CollisionChecker, a, b, step: float | None = None) -> bool:
    """Is the straight motion a -> b free?

    step None: the continuous check (exact for boxes). A step: the T-RO code's discretised
    steerTo, states no farther apart than `step` (a coarse step can cut a corner, which is
    why MPNet's feasibility check stays continuous).
    """
    if step is None:
        return checker.motion_valid(a, b)
    return bool(checker.states_valid(interpolate(checker.spec, a, b, step)).all())


def is_feasible(checker: CollisionChecker, path: Sequence) -> bool:
    """Every state and every segment of the path is free."""
    if len(path) == 0:
        return False
    if len(path) == 1:
        return bool(checker.is_valid(path[0]))
    p = np.asarray(path, float)
    return bool(checker.motions_valid(p[:-1], p[1:]).all())


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
    """States along a -> b no farther apart than `step` in workspace units (the space's
    motion length: for the rigid body, how far any point of the body moves)."""
    return spec.space.interpolate(a, b, step)


def interpolate_path(spec: EnvSpec, path: np.ndarray, step: float) -> np.ndarray:
    """Every segment of the path sampled as `interpolate` does, in one vectorised pass."""
    return spec.space.interpolate_path(path, step)


def verify_path(spec: EnvSpec, ws: Workspace, path, start, goal, step: float | None = None) -> str | None:
    """The independent fine re-check (docs/reliability.md, "What the numbers mean"): None when
    the path is a success, else why not.

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
    ok = spec.judge_checker(ws).states_valid(samples)
    if ok.all():
        return None
    bad = samples[~ok][0]
    return "out_of_bounds" if not spec.in_bounds(bad) else "collision"
