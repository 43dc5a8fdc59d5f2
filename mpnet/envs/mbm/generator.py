"""panda_mbm's workspaces and queries (issue 26): scenes of MotionBenchMaker's seven Panda
families and queries made as MBM's generator makes them (scripts/generate.cpp,
ProblemGenerator): the start is MBM's "ready" state (table_under_pick: inverse kinematics
under the table top), the goal is inverse kinematics to the pose one of the family's goal
objects asks of panda_link8, and both must be valid. A scene with no valid start or goal is
drawn again, as MBM does.

Workspace i is of family FAMILY_ORDER[i % 7] and depends on (seed, i) only. Where we differ
from MBM, and why: MBM validated each query with a MoveIt planner given 60 s; test queries
here pass the env's RRT-Connect screen (`solvable_s`), expert paths the expert's RRT*. MBM's
IK is KDL with 200 restarts of 0.01 s; ours is mpnet.envs.arm.ik with the same number of
restarts. MBM's 700 packaged problems are test data: nothing here reads them.
"""

from __future__ import annotations

import os
from functools import cached_property

import numpy as np

from mpnet.envs.arm.ik import IKTarget, solve
from mpnet.envs.checkers.collision import CollisionChecker
from mpnet.envs.mbm.scenes import PoseQuery, SceneFamily, default_start, families, ik_tip
from mpnet.envs.spec import EnvSpec
from mpnet.envs.workspace import Workspace

FAMILY_ORDER = (
    "bookshelf_small",
    "bookshelf_tall",
    "bookshelf_thin",
    "box",
    "cage",
    "table_pick",
    "table_under_pick",
)


def poses_of(family: SceneFamily, ws: Workspace) -> dict[str, np.ndarray]:
    """Every object's 4 x 4 pose, read back from the workspace by the objects' names (its
    primitives are in a canonical order, not the family's)."""
    named = {p.name: p for p in ws.primitives if p.name is not None}
    missing = [o.name for o in family.objects if o.name not in named]
    if missing:
        raise ValueError(
            f"workspace {ws.id!r}: not a generated {family.name} scene (its objects {', '.join(missing)} are not "
            f"named among its {len(ws.primitives)} obstacles)"
        )
    out = {}
    for o in family.objects:
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = named[o.name].rotation(), named[o.name].center
        out[o.name] = m
    return out


def ik_to(
    model, tip: str, family: SceneFamily, poses, query: PoseQuery, name: str, rng, seed_q, checker, attempts: int
):
    """A valid joint vector putting link `tip` where `query` asks at object `name`, or None."""
    target = IKTarget(tip, family.tip_targets(poses, query)[name], query.position_tol, query.orientation_tol)
    return solve(model, target, rng, seed_q=seed_q, attempts=attempts, valid=lambda q: checker.is_valid(q.tolist()))


def _any(objects, rng) -> str:
    return objects[int(rng.integers(len(objects)))]


class MBMScenes:
    """panda_mbm's generator: `make` draws scene i until it has a valid start and a valid
    goal (MBM's redraw), `pairs` yields MBM's queries in a scene: the start, and a goal by IK
    at a goal object drawn at random (table_under_pick: a start by IK too). It ends when
    `goal_failures` IK calls in a row found nothing for every goal object, or for the start
    (IK is random: an object given up on may have been reachable; that costs variety, never
    a wrong pair)."""

    VERSION = 2  # in the data and test set keys: bumped when a change can change a scene or query (2: compiled IK)
    split_sizes = (7000, 700)  # training (seen) ids 0-6999, unseen 7000-7699: 1000 and 100 per family
    more_seen = True  # a scene of any id: training goes on at 7700 (split_ids), 7700 % 7 == 0 keeps the families even

    def __init__(self, robot, scenes: str, ik_attempts: int = 200, scene_attempts: int = 200, goal_failures: int = 3):
        self.robot, self.scenes = robot, scenes  # scenes: the robot's family file in data_files/mbm
        self.ik_attempts, self.scene_attempts, self.goal_failures = ik_attempts, scene_attempts, goal_failures

    def family_of(self, ws: Workspace) -> SceneFamily:
        """The family of a generated workspace (its id is its index)."""
        return families(self.scenes)[FAMILY_ORDER[int(ws.id) % len(FAMILY_ORDER)]]

    def _ik(self, family: SceneFamily, poses, query: PoseQuery, name: str, rng, seed_q, checker):
        tip = ik_tip(self.scenes)
        return ik_to(self.robot.model, tip, family, poses, query, name, rng, seed_q, checker, self.ik_attempts)

    @cached_property
    def _screen(self) -> EnvSpec:
        """The spec the scene screen checks with: the robot's default checker, no margin."""
        return EnvSpec("mbm-screen", self.robot.joint_space(), self.robot, 3, self, planning_margin=0.0)

    def _start(self, family: SceneFamily, poses, checker: CollisionChecker, rng) -> np.ndarray | None:
        if family.starts is None:
            start = default_start(self.scenes)
            return start if checker.is_valid(start.tolist()) else None
        name = _any(family.starts.objects, rng)
        return self._ik(family, poses, family.starts, name, rng, default_start(self.scenes), checker)

    def _goal(self, family: SceneFamily, poses, checker, rng, start, name: str) -> np.ndarray | None:
        return self._ik(family, poses, family.goals, name, rng, start, checker)

    def make(self, index: int, split: str, seed: int = 0) -> Workspace:
        family = families(self.scenes)[FAMILY_ORDER[index % len(FAMILY_ORDER)]]
        for attempt in range(self.scene_attempts):
            rng = np.random.default_rng([seed, 26, index, attempt])
            poses = family.sample(rng)
            ws = Workspace(str(index), split, np.zeros((0, 3)), np.zeros((0, 3)), family.primitives(poses))
            checker = self._screen.make_checker(ws)
            start = self._start(family, poses, checker, rng)
            name = _any(family.goals.objects, rng)
            if start is not None and self._goal(family, poses, checker, rng, start, name) is not None:
                return ws
        raise RuntimeError(f"{family.name} scene {index}: no valid query in {self.scene_attempts} draws")

    def make_many(self, indices: list[int], split: str, seed: int = 0) -> list[Workspace]:
        """Several scenes; many are drawn in parallel (a scene's screen takes about a second
        of IK, and a training set has hundreds)."""
        if len(indices) < 8:
            return [self.make(i, split, seed) for i in indices]
        from mpnet.workers import process_pool

        with process_pool(os.cpu_count() or 1) as pool:
            return list(pool.map(self.make, indices, [split] * len(indices), [seed] * len(indices), chunksize=4))

    def pairs(self, spec: EnvSpec, ws: Workspace, checker: CollisionChecker, rng: np.random.Generator):
        family = self.family_of(ws)
        poses = poses_of(family, ws)
        misses = dict.fromkeys(family.goals.objects, 0)  # IK calls in a row that found nothing, per object
        failures = 0
        while misses and failures < self.goal_failures:
            start = self._start(family, poses, checker, rng)
            if start is None:
                failures += 1
                continue
            name = _any(list(misses), rng)
            goal = self._goal(family, poses, checker, rng, start, name)
            if goal is None:
                misses[name] += 1
                if misses[name] == self.goal_failures:
                    del misses[name]
                continue
            failures, misses[name] = 0, 0
            yield start, goal
