"""OMPL state spaces and checkers for an env: one fresh space per setup (a shared space
crashed OMPL's Benchmark), validity through the shared counted checker, and an exact
motion validator (OMPL's discrete motion checking cuts box corners)."""
from __future__ import annotations

from ompl import base as ob

from mpnet.envs.collision import CollisionChecker
from mpnet.envs.workspace import EnvSpec, wrap_angle


class ExactMotionValidator(ob.MotionValidator):
    """Delegates checkMotion to the checker's continuous test."""

    def __init__(self, si, checker: CollisionChecker, to_tuple):
        super().__init__(si)
        self._checker = checker
        self._to_tuple = to_tuple

    def checkMotion(self, s1, s2):
        return self._checker.motion_valid(self._to_tuple(s1), self._to_tuple(s2))


def make_space(spec: EnvSpec):
    if spec.is_se2:
        space = ob.SE2StateSpace()
        b = ob.RealVectorBounds(2)
        for d in range(2):
            b.setLow(d, spec.bounds[d][0])
            b.setHigh(d, spec.bounds[d][1])
        space.setBounds(b)
    else:
        space = ob.RealVectorStateSpace(spec.state_dim)
        b = ob.RealVectorBounds(spec.state_dim)
        for d, (lo, hi) in enumerate(spec.bounds):
            b.setLow(d, lo)
            b.setHigh(d, hi)
        space.setBounds(b)
    return space


def state_codec(spec: EnvSpec):
    """(to_tuple, set_state) for the env's OMPL state type."""
    if spec.is_se2:
        def to_tuple(s):
            return (s.getX(), s.getY(), s.getYaw())

        def set_state(s, q):
            s.setX(float(q[0]))
            s.setY(float(q[1]))
            s.setYaw(wrap_angle(float(q[2])))  # OMPL's SO2 expects [-pi, pi)
    else:
        n = spec.state_dim

        def to_tuple(s):
            return tuple(s[i] for i in range(n))

        def set_state(s, q):
            for i in range(n):
                s[i] = float(q[i])
    return to_tuple, set_state


def make_space_information(spec: EnvSpec, checker: CollisionChecker):
    """SpaceInformation whose validity and motion checks go through `checker`.

    Returns (si, to_tuple, set_state, keep): keep holds Python objects OMPL only
    references, so they live as long as the setup.
    """
    space = make_space(spec)
    si = ob.SpaceInformation(space)
    to_tuple, set_state = state_codec(spec)
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
    planner.solve(ob.timedPlannerTerminationCondition(seconds))
    return bool(pdef.hasExactSolution())
