"""MotionBenchMaker-style problems (issue 26): a scene of one of MBM's Panda families and one
query in it, made as MBM's generator makes them (scripts/generate.cpp, ProblemGenerator):
the start is MBM's "ready" state (table_under_pick: inverse kinematics under the table top),
the goal is inverse kinematics to the pose one of the family's goal objects asks of
panda_link8, and the pair is kept only when both are valid and RRT-Connect solves it. Any
failure gives None, and the caller draws a new scene, as MBM does.

Where we differ from MBM, and why: MBM validated with a MoveIt planner given 60 s and two
attempts; we use the env's `solvable_s` with OMPL's RRT-Connect (the screen every generated
test query passes). MBM's IK is KDL with 200 restarts of 0.01 s; ours is mpnet.envs.arm_ik
with the same number of restarts.
"""

from __future__ import annotations

import numpy as np

from mpnet.envs.arm_ik import IKTarget, solve
from mpnet.envs.mbm_scenes import SceneFamily, default_start
from mpnet.envs.ompl_space import is_solvable
from mpnet.envs.spec import EnvSpec
from mpnet.envs.workspace import Query, Workspace

TIP = "panda_link8"  # MBM's IK tip: the SRDF's panda_arm chain ends there


def _ik(spec: EnvSpec, family: SceneFamily, poses, query, rng, seed_q, checker, attempts) -> np.ndarray | None:
    name = query.objects[int(rng.integers(len(query.objects)))]
    target = IKTarget(TIP, family.link8_targets(poses, query)[name], query.position_tol, query.orientation_tol)
    return solve(
        spec.robot.model, target, rng, seed_q=seed_q, attempts=attempts, valid=lambda q: checker.is_valid(q.tolist())
    )


def make_problem(
    spec: EnvSpec,
    family: SceneFamily,
    rng: np.random.Generator,
    workspace_id: str,
    split: str,
    *,
    solvable_s: float = 2.0,
    ik_attempts: int = 200,
) -> tuple[Workspace, Query] | None:
    """One scene of `family` and one query in it, or None when this scene gives none."""
    poses = family.sample(rng)
    ws = Workspace(workspace_id, split, np.zeros((0, 3)), np.zeros((0, 3)), family.primitives(poses))
    checker = spec.make_checker(ws)
    start = default_start()
    if family.starts is not None:
        start = _ik(spec, family, poses, family.starts, rng, start, checker, ik_attempts)
        if start is None:
            return None
    if not checker.is_valid(start.tolist()):
        return None
    goal = _ik(spec, family, poses, family.goals, rng, start, checker, ik_attempts)
    if goal is None or not is_solvable(spec, checker, start, goal, solvable_s):
        return None
    return ws, Query(f"{workspace_id}/0", workspace_id, split, start, goal)
