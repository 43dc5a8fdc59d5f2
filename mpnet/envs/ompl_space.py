"""OMPL state spaces and checkers for an env: one fresh space per setup (a shared space
crashed OMPL's Benchmark), validity through the shared counted checker, and an exact
motion validator (OMPL's discrete motion checking cuts box corners); OMPL's seeding, the
one path every caller takes (a run's, a query's, a worker process's); and its time limits, on
the harness's clock."""

from __future__ import annotations

import time

import numpy as np
from ompl import base as ob
from ompl import util as ou

from mpnet.envs.checkers.collision import CollisionChecker
from mpnet.envs.spec import EnvSpec


class ExactMotionValidator(ob.MotionValidator):
    """Delegates checkMotion to the checker's continuous test."""

    def __init__(self, si, checker: CollisionChecker, to_tuple):
        super().__init__(si)
        self._checker = checker
        self._to_tuple = to_tuple

    def checkMotion(self, s1, s2):
        return self._checker.motion_valid(self._to_tuple(s1), self._to_tuple(s2))


def make_space_information(spec: EnvSpec, checker: CollisionChecker):
    """SpaceInformation whose validity and motion checks go through `checker`.

    Returns (si, to_tuple, set_state, keep): keep holds Python objects OMPL only
    references, so they live as long as the setup.
    """
    space = spec.space.ompl_space()
    si = ob.SpaceInformation(space)
    to_tuple, set_state = spec.space.ompl_codec()
    is_valid = checker.is_valid
    si.setStateValidityChecker(lambda s: is_valid(to_tuple(s)))
    mv = ExactMotionValidator(si, checker, to_tuple)
    si.setMotionValidator(mv)
    si.setup()
    return si, to_tuple, set_state, (space, mv)


def make_problem(spec: EnvSpec, checker: CollisionChecker, start, goal):
    """A ProblemDefinition from start to goal with a path-length objective over a fresh
    SpaceInformation. Returns (si, pdef, to_tuple, keep) (keep: see make_space_information)."""
    si, to_tuple, set_state, keep = make_space_information(spec, checker)
    s, g = si.allocState(), si.allocState()
    set_state(s, start)
    set_state(g, goal)
    pdef = ob.ProblemDefinition(si)
    pdef.setStartAndGoalStates(s, g)
    objective = ob.PathLengthOptimizationObjective(si)
    pdef.setOptimizationObjective(objective)
    return si, pdef, to_tuple, (*keep, s, g, objective)


def is_solvable(spec: EnvSpec, checker: CollisionChecker, start, goal, seconds: float) -> bool:
    """Does RRT-Connect find a path within `seconds`? (Screens generated queries so that
    no test query lies in a pocket no planner can leave.)"""
    from ompl import geometric as og

    si, pdef, _, keep = make_problem(spec, checker, start, goal)
    planner = og.RRTConnect(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    planner.solve(deadline_condition(seconds))
    return bool(pdef.hasExactSolution())


def deadline_condition(seconds: float, clock=time.perf_counter):
    """Stop OMPL once `seconds` have passed on `clock`, the monotonic clock trials are timed
    with. OMPL's own timed condition reads the wall clock, which NTP or a resumed VM steps: a
    planner it stopped early was then neither a timeout by the trial's clock nor a real failure."""
    end = clock() + seconds
    return ob.PlannerTerminationCondition(lambda: clock() >= end)


def set_ompl_seed(value: int) -> None:
    """OMPL's seed generator restarted at `value` (in [1, 2^31 - 1]). OMPL logs an
    error when seeding after its first draw, since RNGs that already exist keep their streams;
    the RNGs that matter are made after it (a query's planner, a run's own), so it is muted."""
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    try:
        ou.RNG.setSeed(int(value))
    finally:
        ou.setLogLevel(level)


def seed_worker(seed: int, stream: int, chunk: int, seeded: bool = True) -> None:
    """A worker process's OMPL, before its chunk of work: warnings and errors only, and (when
    `seeded`) its seed generator started from numpy's first integer in [1, 2^31 - 1) of
    (seed, stream, chunk), so a chunk's draws depend on its number alone, whatever process runs it."""
    ou.setLogLevel(ou.LOG_WARN)
    if seeded:
        set_ompl_seed(int(np.random.default_rng([seed, stream, chunk]).integers(1, 2**31 - 1)))
