"""MotionBenchMaker-style problems (mpnet.envs.mbm_problems): the start and goal are valid,
the goal puts panda_link8 where the query asks, and RRT-Connect solves the pair."""

from __future__ import annotations

import numpy as np
import pytest

from mpnet.envs.arm_ik import IKTarget, meets
from mpnet.envs.mbm_problems import TIP, make_problem
from mpnet.envs.mbm_scenes import default_start, families
from mpnet.envs.specs import get_spec

ARM = get_spec("arm7")
FAMILIES = families()


def _first_problem(name: str, tries: int = 15):
    rng = np.random.default_rng(3)
    for i in range(tries):
        out = make_problem(ARM, FAMILIES[name], rng, f"{name}/{i:04d}", "seen", ik_attempts=40)
        if out is not None:
            return out
    pytest.fail(f"{name}: no problem in {tries} scenes")


@pytest.mark.parametrize("name", ["bookshelf_small", "table_under_pick"])
def test_a_problem_is_valid_reaches_its_target_and_is_solvable(name):
    ws, q = _first_problem(name)
    checker = ARM.make_checker(ws)
    assert checker.is_valid(q.start.tolist()) and checker.is_valid(q.goal.tolist())
    f = FAMILIES[name]
    if f.starts is None:
        assert np.allclose(q.start, default_start())
    # the goal meets one of the goal objects' panda_link8 targets, computed from the objects'
    # poses as the workspace holds them (the data's object order)
    model = ARM.robot.model
    assert len(ws.primitives) == len(f.objects)
    assert any(meets(model, q.goal, _target(f, ws, n)) for n in f.goals.objects)


def _target(f, ws, name) -> IKTarget:
    p = ws.primitives[[o.name for o in f.objects].index(name)]
    pose = np.eye(4)
    pose[:3, :3] = p.rotation()
    pose[:3, 3] = p.center
    link8 = pose @ f.goals.offset @ np.linalg.inv(f.ee_offset)
    return IKTarget(TIP, link8, f.goals.position_tol, f.goals.orientation_tol)
