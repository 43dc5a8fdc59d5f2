"""MPNet's planner with its loop compiled (mpnet.planners.compiled.kernels) and Enet's encoding
(mpnet.models.enet_kernel): the numpy planner's method and decisions, call for call, so the
same paths; Algorithm 1's few rounds and HR's classical planner stay in Python around the
compiled pieces. (The point robots' clouds are drawn compiled for every planner:
mpnet.envs.scenes.clouds.)

The budget is checked between compiled calls (one NeuralPlanner run of at most max_steps
steps, one contraction, one feasibility check), not inside them: a call's steps are bounded.
The stats' `pnet_s` holds each NeuralPlanner run's whole time (Pnet and its steerTo checks,
which run together in compiled code), `steer_s` stays 0.
"""

from __future__ import annotations

import time
from itertools import repeat

import numpy as np

from mpnet.models.enet_kernel import EnetKernel
from mpnet.models.numpy_nets import NumpyEnet
from mpnet.models.pnet_kernel import PnetKernel
from mpnet.planners.base import Problem, Result
from mpnet.planners.compiled import kernels as K
from mpnet.planners.neural import MPNetPlanner, repair_path

PROPOSAL_KINDS = {"pnet": K.PNET, "random": K.RANDOM, "random_any": K.RANDOM_ANY, "straight": K.STRAIGHT}


def supports(spec, backend: str | None = None) -> bool:
    """Whether the env's checker of this collision backend (None: the robot's default) has a
    compiled form (CollisionChecker.compiled)."""
    robot = spec.robot
    checker = robot.checkers.get(backend or robot.default_backend)
    return bool(getattr(checker, "compiled", False))


def kernel_env(checker) -> tuple:
    """The checker's compiled form, the compiled planner's `env` tuple (compiled_kernels)."""
    return checker.compiled_env()


class CompiledMPNetPlanner(MPNetPlanner):
    """MPNetPlanner with NeuralPlanner, steerTo, contraction and the feasibility check compiled.
    Takes the numpy export of Pnet (`net`, a NumpyPnet with its normaliser) besides the settings,
    and `clip` (Pnet's proposals clipped into the bounds, as MPNetSettings.clip); every proposal
    (Pnet's and the ablations'), continuous steerTo only."""

    def __init__(self, name, encode, net, cloud, clip: bool = False, **settings):
        if settings.get("steer_steps"):
            raise ValueError("config key planner.compiled: continuous steerTo only (steer_steps: null)")
        self.net, self.kernel = net, PnetKernel(net)
        if isinstance(encode, NumpyEnet):  # Enet's encoding compiled too (a zero code stays as given)
            encode = EnetKernel(encode)
        super().__init__(name, encode, self.kernel.step, cloud, **settings)
        self.clip = bool(clip)
        self._props: dict[int, tuple] = {}  # id(spec) -> (spec, the kernel's proposal tuple)
        self.compiled_dropout = bool(settings.get("dropout", True))
        self._envs: dict[int, tuple] = {}  # id(checker) -> (checker, its kernel env)
        self._memo = K.new_memo(net.state_dim)
        self._counts = np.zeros(3, np.int64)  # states, motions, configurations (SampledConfigurations)
        self._buf = self.kernel.buffers
        steps = max(self.max_steps, self.replan_steps)
        self._tree_buf = np.empty((2, steps + 1, net.state_dim))
        self._trace_buf = np.empty((steps, 2, net.state_dim))

    def env_of(self, checker) -> tuple:
        """The checker's kernel env, made once per checker."""
        known = self._envs.get(id(checker))
        if known is None or known[0] is not checker:  # a new checker (an id may be reused)
            known = self._envs[id(checker)] = (checker, kernel_env(checker))
        return known[1]

    def solve(self, problem: Problem, budget_s: float, **given) -> Result:
        """MPNetPlanner.solve (`given`: batched planning's code and first run)."""
        raw = problem.checker
        self.env = self.env_of(raw)
        self.prop = self.prop_of(problem.spec)
        self._memo[1].fill(-1)
        self._memo[2][0] = 0
        self._counts[:] = 0
        try:
            return super().solve(problem, budget_s, **given)
        finally:
            raw.state_checks += int(self._counts[0])
            raw.motion_checks += int(self._counts[1])
            if hasattr(raw, "configurations"):
                raw.configurations += int(self._counts[2])

    def prop_of(self, spec) -> tuple:
        """The kernel's `prop` for the env, made once per spec: kind, clip, straight step, the
        space's lower, upper, half-widths."""
        known = self._props.get(id(spec))
        if known is None or known[0] is not spec:
            space = spec.space
            bounds = (np.ascontiguousarray(v, float) for v in (space.lower, space.upper, space.half_widths()))
            known = self._props[id(spec)] = (
                spec,
                (PROPOSAL_KINDS[self.proposal], self.clip, self.straight_step, *bounds),
            )
        return known[1]

    def warm_up(self, problem: Problem) -> None:
        """Every kernel called once on the problem's ends, with no budget: compiled, or loaded
        from numba's on-disk cache, before the first timed query (Planner.warm_up). (A short
        solve would not do: on a cold cache the cloud's and Enet's compilation outlasts its
        budget, and the loop's kernels were then compiled inside the first timed query.)"""
        z = self.encode(self.cloud(problem.workspace))
        env, memo, counts = self.env_of(problem.checker), K.new_memo(self.net.state_dim, 4), np.zeros(3, np.int64)
        prop = self.prop_of(problem.spec)
        start, goal = np.asarray(problem.start, float), np.asarray(problem.goal, float)
        K.neural_planner(
            np.asarray(z, np.float32), start, goal, 1, True, env, memo, counts, prop, self.kernel.args,
            np.random.default_rng(0), self.compiled_dropout, self._buf, self._tree_buf, self._trace_buf,
        )  # fmt: skip
        path = np.stack([start, goal])
        K.contract(env, memo, counts, path)
        K.is_feasible(env, memo, counts, path)
        K.is_valid(env, counts, start)
        K.motion_valid(env, memo, counts, start, goal)

    def neural_planner(self, problem, z, start, goal, max_steps, stats, deadline, step=None, stage=0, precheck=False):
        if time.perf_counter() > deadline:
            return None
        t = time.perf_counter()
        rng = self.rng
        connected, n0, n1, steps = K.neural_planner(
            np.asarray(z, np.float32), np.asarray(start, float), np.asarray(goal, float), max_steps, precheck,
            self.env, self._memo, self._counts, self.prop, self.kernel.args, rng, self.compiled_dropout, self._buf,
            self._tree_buf, self._trace_buf,
        )  # fmt: skip
        stats["pnet_s"] += time.perf_counter() - t
        stats["pnet_calls"] += steps
        trace = self._trace_buf[:steps].copy()  # rows of one copy: the diagnostics read them after the query
        self.trace.extend(zip(repeat(stage, steps), trace[:, 0], trace[:, 1]))
        a = [start, *self._tree_buf[0, 1:n0].copy()]
        b = [goal, *self._tree_buf[1, 1:n1].copy()]
        if connected:
            return a + b[::-1]
        self._trees = (a, b)
        return None

    def adopt_run(self, counts, trace, trees) -> None:
        """A first NeuralPlanner run planned outside this planner (batched planning's lockstep),
        taken as its own: its checks counted, its trace kept, and its trees (None: it
        connected) left for replanning, as neural_planner leaves them."""
        self._counts += counts
        self.trace.extend((0, x, y) for x, y in trace)
        if trees is not None:
            self._trees = trees

    def repair(self, checker, path, connect, step=None, stop_on_fail: bool = False):
        """neural.repair_path on the compiled memo (continuous steerTo): neural replanning's and
        HR's segments checked as MPNetPlanner checks them."""
        env, memo, counts = self.env, self._memo, self._counts
        return repair_path(
            lambda q: K.is_valid(env, counts, np.asarray(q, float)),
            lambda x, y: K.motion_valid(env, memo, counts, np.asarray(x, float), np.asarray(y, float)),
            path,
            connect,
            stop_on_fail,
        )

    def contract(self, checker, path, step, stats: dict) -> list:
        t = time.perf_counter()
        keep = K.contract(self.env, self._memo, self._counts, np.asarray(path, float))
        stats["contract_s"] += time.perf_counter() - t
        return [path[i] for i in keep]

    def feasible(self, checker, path, stats: dict) -> bool:
        t = time.perf_counter()
        ok = K.is_feasible(self.env, self._memo, self._counts, np.asarray(path, float).reshape(len(path), -1))
        stats["feasible_s"] += time.perf_counter() - t
        return bool(ok)
