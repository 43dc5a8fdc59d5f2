"""The env registry: each env's space, robot, generator and cloud (docs/environments.md). A new
kind of robot adds its space, robot and checker classes and an entry here."""

from __future__ import annotations

from mpnet.envs.mbm.generator import MBMScenes
from mpnet.envs.robots import ArmRobot, PointRobot, RectangleRobot
from mpnet.envs.scenes.arm_scenes import ArmScenes, arm_cloud
from mpnet.envs.scenes.generators import C2D_SIZES, C3DLayouts, OriginalLayouts
from mpnet.envs.spaces import EuclideanSpace, SE2Space
from mpnet.envs.spec import EnvSpec

_BOX = ((-20.0, 20.0),)
_RIGID = RectangleRobot((2.0, 5.0))
_PANDA = ArmRobot("panda")
_MBM_SCENES = MBMScenes(_PANDA)


def _panda(name: str, generator, **kwargs) -> EnvSpec:
    """An env of the Panda: its joint space, surface clouds of 10 x points_per_block points
    in metres, the judge's 0.002 rad re-check, no planning margin."""
    return EnvSpec(
        name,
        _PANDA.joint_space(),
        _PANDA,
        3,
        generator,
        blocks=10,
        validation_step=0.002,
        sample_cloud=arm_cloud,
        motion_step=0.02,
        planning_margin=0.0,
        cloud_scale=(1.0, 1.0, 1.0),
        **kwargs,
    )


SPECS: dict[str, EnvSpec] = {
    "s2d": EnvSpec("s2d", EuclideanSpace(_BOX * 2), PointRobot(), 2, OriginalLayouts(), exact_reference=True),
    "c2d": EnvSpec("c2d", EuclideanSpace(_BOX * 2), PointRobot(), 2, OriginalLayouts(C2D_SIZES), exact_reference=True),
    "c3d": EnvSpec("c3d", EuclideanSpace(_BOX * 3), PointRobot(), 3, C3DLayouts(), blocks=10),
    "rigid": EnvSpec("rigid", SE2Space(_BOX * 2, radius=_RIGID.radius), _RIGID, 2, OriginalLayouts()),
    # MotionBenchMaker's Franka Panda (the paper's Baxter is not installable): joint vectors
    # within the model's limits, obstacles in metres in the base frame.
    "arm7": _panda("arm7", ArmScenes()),
    # The same Panda in scenes of MotionBenchMaker's seven families, with MBM's queries
    # (mpnet.envs.mbm.generator): the training and test data for MBM's 700 problems (issue 26).
    "panda_mbm": _panda("panda_mbm", _MBM_SCENES, pairs=_MBM_SCENES.pairs),
}


def get_spec(name: str) -> EnvSpec:
    try:
        return SPECS[name]
    except KeyError:
        raise KeyError(f"unknown env {name!r}; choices: {', '.join(sorted(SPECS))}") from None
