"""RRT-Connect's search on an env's compiled checks (mpnet.search.rrt_kernels), run to a
connection, a clock or a number of rounds: what the named planner `rrt_connect_compiled`
(mpnet.planners.compiled.rrt_connect) and the compiled expert (mpnet.data.expert_planners) both run.
Its search is OMPL's RRTConnect (same growth, same maximum edge length: the env's
`planner_range`, else OMPL's default of a fifth of the space's extent) with its own random
stream, so its paths are RRT-Connect's in kind, not OMPL's state for state.

The clock is read between compiled slices of the search (numba has none): each slice is sized
to take about SLICE_S at the mean rate so far, so a budget is overrun by about a slice (the
rounds slow as the trees grow: a few times SLICE_S at worst; the first slice is FIRST_SLICE
rounds whatever they take). Doubling the trees' arrays is not a slice: it starts only when it
should end within the budget (about twice the last doubling's time: twice the memory), else the
search ends there, its trees full. The arrays live in small pages (_small_pages), so that a
doubling takes what its size predicts (in huge pages, under the kernel's compaction, one took
0.19-0.71 s at 262,144-524,288 states, 23-40 ms in small pages). A budget in rounds
(`max_rounds`) ends the search at exactly that many rounds, whatever the machine: the paths then
depend on the seed alone.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math
import mmap
import time
from dataclasses import dataclass
from functools import cache

import numpy as np

from mpnet.search import rrt_kernels as K
from mpnet.search.kd_tree import kd_arrays, kd_grown

SLICE_S = 0.005  # a slice of the search lasts about this long once its rate is known
FIRST_SLICE = 32  # iterations of the first slice: most arm queries connect within it
CAPACITY = 1024  # each tree's first capacity (states); doubled when full
DEFAULT_RANGE_SHARE = 0.2  # OMPL's RRTConnect: maxDistance = 0.2 x the space's maximum extent


def tree_range(spec, given: float | None = None) -> float:
    """A tree planner's maximum edge length: the one given, else the env's `planner_range`,
    else OMPL's default (DEFAULT_RANGE_SHARE of the space's maximum extent)."""
    reach = given if given is not None else spec.planner_range
    return float(reach if reach is not None else DEFAULT_RANGE_SHARE * spec.space.maximum_extent())


@dataclass
class Searched:
    """One search's outcome: the path (None: no connection within the budget), the rounds
    run, the trees' states, the checks (states, motions, configurations evaluated), and
    whether it ended with its trees full (doubling them would not have ended within the budget)."""

    path: np.ndarray | None
    rounds: int
    tree_states: int
    counts: np.ndarray
    full: bool = False


class RRTConnectSearch:
    """The search with its trees' arrays, kept between queries (grown when a search fills
    them). `range`: the maximum edge length (None: the env's `planner_range`, else OMPL's
    default)."""

    def __init__(self, range: float | None = None):
        self.range = range
        self._spaces: dict[int, tuple] = {}  # id(spec) -> (spec, (lower, upper, weights, reach, room))
        self._trees: tuple | None = None

    def space_of(self, spec) -> tuple:
        """(lower, upper, metric weights, maximum edge length, room a round needs), once per spec."""
        known = self._spaces.get(id(spec))
        if known is None or known[0] is not spec:
            space = spec.space
            reach = tree_range(spec, self.range)
            # a connection adds at most (extent / reach + 1) states to a tree: room for one round
            room = int(np.ceil(space.maximum_extent() / reach)) + 4
            lower, upper = (np.ascontiguousarray(v, float) for v in (space.lower, space.upper))
            known = self._spaces[id(spec)] = (spec, (lower, upper, space.metric_weights(), reach, room))
        return known[1]

    @staticmethod
    def _arrays(cap: int, d: int) -> tuple:
        """The trees' arrays for `cap` states each: nodes (2, cap, d), parents (2, cap), the
        nodes column by column (2, d, cap), nearest's distances (cap,) and the k-d trees, in
        small pages (_small_pages)."""
        arrays = (
            np.empty((2, cap, d)),
            np.zeros((2, cap), np.int64),
            np.empty((2, d, cap)),
            np.empty(cap),
            kd_arrays(cap),
        )
        _small_pages(*arrays[:4], *arrays[4])
        return arrays

    def _buffers(self, d: int, room: int) -> tuple:
        """The trees' arrays (_arrays), kept between queries."""
        if self._trees is None or self._trees[0].shape[2] != d or self._trees[0].shape[1] < 2 * room:
            self._trees = self._arrays(max(CAPACITY, 2 * room), d)
        return self._trees

    def _grown(self) -> tuple:
        """The trees' arrays at twice their capacity, every state and parent kept."""
        nodes, parents, cols, _, kd = self._trees
        cap = nodes.shape[1]
        more = self._arrays(2 * cap, nodes.shape[2])
        more[0][:, :cap], more[1][:, :cap], more[2][:, :, :cap] = nodes, parents, cols
        self._trees = (*more[:4], kd_grown(kd, more[4]))
        return self._trees

    def _roots(self, start, goal, room: int) -> tuple:
        """The trees' arrays with start and goal their roots."""
        nodes, parents, cols, dist, kd = self._buffers(len(start), room)
        nodes[0, 0], nodes[1, 0] = start, goal
        cols[0, :, 0], cols[1, :, 0] = start, goal
        return nodes, parents, cols, dist, kd

    def run(
        self, env, spec, start, goal, rng, deadline: float = math.inf, max_rounds: int | None = None, counts=None
    ) -> Searched:
        """Search from start to goal on the checker's compiled form `env` until connected,
        `deadline` (time.perf_counter's) or `max_rounds` rounds (no path and 0 rounds when start
        or goal is not free). rng: the kernels' splitmix64 state (one uint64, advanced in
        place); counts: the checks are added into it (int64 (3,), the caller's, so that a
        search stopped by an exception still counts them)."""
        t0 = time.perf_counter()
        lower, upper, weights, reach, room = self.space_of(spec)
        start, goal = np.asarray(start, float), np.asarray(goal, float)
        nodes, parents, cols, dist, kd = self._roots(start, goal, room)
        state = K.new_state()
        counts = np.zeros(3, np.int64) if counts is None else counts
        sample, diff = np.empty(start.shape[0]), np.empty(start.shape[0])
        chunk, outcome, doubling_s, full = FIRST_SLICE, K.RUNNING, 0.0, False
        if not K.roots_free(env, counts, start, goal):  # the motions' checks skip the trees' states
            return Searched(None, 0, 2, counts)
        while True:
            if max_rounds is not None:
                chunk = min(chunk, max_rounds - int(state[K.ROUNDS]))
                if chunk <= 0:
                    break
            outcome = K.grow(
                env, counts, weights, lower, upper, reach, rng, nodes, parents, cols, dist, kd, state, chunk, room,
                sample, diff,
            )  # fmt: skip
            if outcome == K.FULL:
                now = time.perf_counter()
                if now + 2 * doubling_s >= deadline:
                    full = True
                    break
                nodes, parents, cols, dist, kd = self._grown()
                doubling_s = time.perf_counter() - now
            now = time.perf_counter()
            if outcome == K.CONNECTED or now >= deadline:
                break
            per = max(now - t0, 1e-9) / state[K.ROUNDS]
            chunk = int(max(1, min(SLICE_S, deadline - now) / per))
        path = K.solution(nodes, parents, state) if outcome == K.CONNECTED else None
        return Searched(path, int(state[K.ROUNDS]), int(state[K.N0] + state[K.N1]), counts, full)

    def warm_up(self, env, spec, start, goal) -> None:
        """The search's kernels compiled (or loaded from numba's cache): the roots' check, the
        rounds' kernel called for no round (a search from a blocked root never reaches it, and
        random states on an arm mostly are blocked: every process that planned first had
        compiled it again, ~40 s on an arm), and a path read back (the two roots joined)."""
        lower, upper, weights, reach, room = self.space_of(spec)
        start, goal = np.asarray(start, float), np.asarray(goal, float)
        nodes, parents, cols, dist, kd = self._roots(start, goal, room)
        state, counts = K.new_state(), np.zeros(3, np.int64)
        K.roots_free(env, counts, start, goal)
        K.grow(
            env, counts, weights, lower, upper, reach, np.zeros(1, np.uint64), nodes, parents, cols, dist, kd, state,
            0, room, np.empty(start.shape[0]), np.empty(start.shape[0]),
        )  # fmt: skip
        state[K.JOIN0], state[K.JOIN1] = 0, 0
        K.solution(nodes, parents, state)


def _small_pages(*arrays: np.ndarray) -> None:
    """The arrays' memory in the kernel's small pages (madvise MADV_NOHUGEPAGE; Linux only, else
    nothing). Why: numpy asks for huge pages for arrays of 4 MB and more, and where the kernel
    then compacts memory to find them (transparent huge pages' defrag `madvise`, as here), a
    doubling of the trees first touched its fresh memory in 0.19-0.71 s at 262,144-524,288
    states, against 23-40 ms in small pages: a doubling's time must be what its size predicts,
    or it overruns the search's budget (RRTConnectSearch.run)."""
    advise = _madvise()
    if advise is None:
        return
    page = mmap.PAGESIZE
    for a in arrays:
        start = -(-a.ctypes.data // page) * page  # the whole pages inside the array
        end = (a.ctypes.data + a.nbytes) // page * page
        if end > start:
            advise(start, end - start, mmap.MADV_NOHUGEPAGE)


@cache
def _madvise():
    """libc's madvise, or None where there is no MADV_NOHUGEPAGE (not Linux)."""
    if not hasattr(mmap, "MADV_NOHUGEPAGE"):
        return None
    name = ctypes.util.find_library("c")
    if name is None:
        return None
    madvise = ctypes.CDLL(name, use_errno=True).madvise
    madvise.argtypes, madvise.restype = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int], ctypes.c_int
    return madvise


def add_counts(checker, counts: np.ndarray) -> None:
    """A search's checks (states, motions, configurations evaluated) counted on the checker,
    as OMPL's planners' are."""
    checker.state_checks += int(counts[0])
    checker.motion_checks += int(counts[1])
    if hasattr(checker, "configurations"):
        checker.configurations += int(counts[2])
