"""Expert paths -> Pnet's training samples, and the train/val split: numpy only, so that
what reads pairs (harness.step_error, the tests) does not import Lightning (~4 s).

The split is a pure function of ``seed`` (and ``groups``, when given: whole groups, e.g. whole
paths, go to one side). mpnet.models.datamodule feeds these to Lightning.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np


def split_indices(
    n: int, val_fraction: float, seed: int, groups: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Deterministic (train, val) index arrays, sorted. ``val_fraction`` of the samples (or of
    the groups) go to val; at least one when ``val_fraction > 0`` and there are two or more."""
    if not 0.0 <= val_fraction < 1.0:
        raise ValueError(f"val_fraction must be in [0, 1), got {val_fraction}")
    rng = np.random.default_rng(seed)
    if groups is None:
        keys, inverse = np.arange(n), np.arange(n)
    else:
        groups = np.asarray(groups)
        if groups.shape != (n,):
            raise ValueError(f"groups must have shape ({n},), got {groups.shape}")
        keys, inverse = np.unique(groups, return_inverse=True)
    m = len(keys)
    n_val = int(round(m * val_fraction))
    if val_fraction > 0 and m >= 2:
        n_val = min(max(n_val, 1), m - 1)
    val_keys = np.zeros(m, dtype=bool)
    val_keys[rng.permutation(m)[:n_val]] = True
    is_val = val_keys[inverse]
    return np.flatnonzero(~is_val), np.flatnonzero(is_val)


class Pairs(NamedTuple):
    ws_index: np.ndarray  # (n,) int64
    x_t: np.ndarray  # (n, state_dim)
    x_goal: np.ndarray  # (n, state_dim)
    x_next: np.ndarray  # (n, state_dim)
    path_id: np.ndarray  # (n,) int64: the index of the source path (for ``groups``)


def resample_path(path: np.ndarray, step: float, space=None) -> np.ndarray:
    """The path with each segment cut into ``ceil(length / step)`` equal pieces (length: the
    space's ``distance``, else Euclidean), so that consecutive states are at most ``step``
    apart; the path's own states stay. A named variant of the training data (issue 26): the
    expert's contracted paths put waypoints ~1.3 rad apart on the arm, and Pnet regresses
    the mean of such far, multimodal next states."""
    if not step > 0:
        raise ValueError(f"waypoint_step must be positive, got {step}")
    path = np.asarray(path, dtype=np.float64)
    if len(path) < 2:
        return path
    if space is None:
        d = path[1:] - path[:-1]
        lengths = np.linalg.norm(d, axis=1)
    else:
        d = space.difference(path[:-1], path[1:])
        lengths = np.array([space.distance(a, b) for a, b in zip(path[:-1], path[1:])])
    pieces = np.maximum(1, np.ceil(lengths / step - 1e-9).astype(int))
    parts = [path[i] + (np.arange(k)[:, None] / k) * d[i] for i, k in enumerate(pieces)]
    return np.concatenate([*parts, path[-1:]])


def _resample_step(path: np.ndarray, space, waypoint_step: float | None, min_waypoints: int | None) -> float | None:
    """The step resample_path takes for this path: waypoint_step, or shorter where the path
    would have fewer than min_waypoints states (its length over min_waypoints - 1)."""
    if min_waypoints is None:
        return waypoint_step
    if min_waypoints < 2:
        raise ValueError(f"min_waypoints must be at least 2, got {min_waypoints}")
    if space is None:
        length = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
    else:
        length = float(sum(space.distance(a, b) for a, b in zip(path[:-1], path[1:])))
    if length <= 0:
        return waypoint_step
    step = length / (min_waypoints - 1)
    return step if waypoint_step is None else min(step, waypoint_step)


GOALS = ("end", "all")  # waypoint_pairs' goal inputs: the path's end (the paper's), or every later waypoint


def _goal_pairs(n: int, goals: str) -> tuple[np.ndarray, np.ndarray]:
    """(j, goal index) of a path of n states: (j, n - 1) for each j < n - 1, or every (j, k), k > j."""
    if goals == "all":
        j, k = np.triu_indices(n, k=1)
        return j, k
    j = np.arange(n - 1)
    return j, np.full(n - 1, n - 1)


def resampled(path: np.ndarray, space, waypoint_step: float | None, min_waypoints: int | None) -> np.ndarray:
    """The path as waypoint_pairs trains on it: resampled at the recipe's step (the path as it
    is where the recipe sets neither option)."""
    step = _resample_step(path, space, waypoint_step, min_waypoints)
    return path if step is None else resample_path(path, step, space)


def waypoint_pairs(
    paths: Sequence[np.ndarray],
    ws_index: Sequence[int],
    bidirectional: bool = True,
    space=None,
    waypoint_step: float | None = None,
    min_waypoints: int | None = None,
    goals: str = "end",
) -> Pairs:
    """Expert paths -> Pnet samples, as the public code: for a path ``x_0..x_T`` every
    ``(x_j, x_T) -> x_{j+1}``; with ``bidirectional`` also the reversed path (the planner grows
    trees from both ends). Paths with fewer than two states add nothing.

    With ``space`` (a StateSpace), samples take the planner's convention: ``x_j`` and ``x_T``
    in canonical coordinates (angles wrapped, as the planner feeds them) and the target
    ``x_j + difference(x_j, x_{j+1})``, the next state as the motion reaches it from ``x_j``
    (an angle may leave [-pi, pi) by less than a step; the planner wraps Pnet's output).

    With ``waypoint_step``, each path is first resampled (:func:`resample_path`); with
    ``min_waypoints`` too, at a step short enough to give it at least that many states (as
    MoveIt interpolates a planned path to at least 10: the paper's Baxter expert paths).

    ``goals="all"`` (a named recipe option, issue 65): every ``(x_j, x_k) -> x_{j+1}`` for
    ``k > j``, the goal input any later waypoint, not the path's end alone: bidirectional
    planning asks Pnet to step toward the other tree's newest state, an intermediate point of
    some path, and a Pnet trained on path ends alone errs there nearly twice as far."""
    if goals not in GOALS:
        raise ValueError(f"goals must be one of {', '.join(GOALS)}, got {goals!r}")
    if len(paths) != len(ws_index):
        raise ValueError(f"{len(paths)} paths but {len(ws_index)} workspace indices")
    cols: dict[str, list] = {"ws": [], "x_t": [], "x_goal": [], "x_next": [], "pid": []}
    dim = None
    for pid, (path, w) in enumerate(zip(paths, ws_index)):
        path = np.asarray(path, dtype=np.float64)
        if path.ndim != 2:
            raise ValueError(f"path {pid} must be (n_states, state_dim), got {path.shape}")
        dim = path.shape[1] if dim is None else dim
        if path.shape[1] != dim:
            raise ValueError(f"path {pid} has state_dim {path.shape[1]}, expected {dim}")
        if len(path) < 2:
            continue
        path = resampled(path, space, waypoint_step, min_waypoints)
        for p in (path, path[::-1]) if bidirectional else (path,):
            j, g = _goal_pairs(len(p), goals)
            k = len(j)
            x_t, x_next, goal = p[j], p[j + 1], p[g]
            if space is not None:
                x_t, goal = space.wrap(x_t), space.wrap(goal)
                x_next = x_t + space.difference(x_t, x_next)
            cols["x_t"].append(x_t)
            cols["x_next"].append(x_next)
            cols["x_goal"].append(goal)
            cols["ws"].append(np.full(k, int(w), dtype=np.int64))
            cols["pid"].append(np.full(k, pid, dtype=np.int64))
    if not cols["x_t"]:
        d = dim or 0
        empty = np.zeros((0, d))
        return Pairs(np.zeros(0, np.int64), empty, empty.copy(), empty.copy(), np.zeros(0, np.int64))
    cat = {k: np.concatenate(v) for k, v in cols.items()}
    return Pairs(cat["ws"], cat["x_t"], cat["x_goal"], cat["x_next"], cat["pid"])
