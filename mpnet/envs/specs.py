"""The env registry: each env's space, robot, generator and cloud (docs/environments.md). A new
kind of robot adds its space, robot and checker classes and an entry here.

An env is built when first asked for, not on import: the arm's envs read the robot's
description (URDF, limits) to make their joint space, which an s2d run never needs."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from functools import cache

from mpnet.envs.mbm.generator import MBMScenes
from mpnet.envs.robots import ArmRobot, PointRobot, RectangleRobot
from mpnet.envs.scenes.arm_scenes import ArmScenes, arm_cloud
from mpnet.envs.scenes.generators import C2D_SIZES, C3DLayouts, OriginalLayouts
from mpnet.envs.spaces import EuclideanSpace, SE2Space
from mpnet.envs.spec import EnvSpec

_BOX = ((-20.0, 20.0),)
_RIGID = RectangleRobot((2.0, 5.0))


@cache
def _panda_robot() -> ArmRobot:
    return ArmRobot("panda")


def _panda(name: str, generator, **kwargs) -> EnvSpec:
    """An env of the Panda: its joint space, surface clouds of 10 x points_per_block points
    in metres, the judge's 0.002 rad re-check, no planning margin."""
    panda = _panda_robot()
    return EnvSpec(
        name,
        panda.joint_space(),
        panda,
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


def _panda_mbm() -> EnvSpec:
    scenes = MBMScenes(_panda_robot())
    return _panda("panda_mbm", scenes, pairs=scenes.pairs)


_BUILDERS: dict[str, Callable[[], EnvSpec]] = {
    "s2d": lambda: EnvSpec("s2d", EuclideanSpace(_BOX * 2), PointRobot(), 2, OriginalLayouts(), exact_reference=True),
    "c2d": lambda: EnvSpec(
        "c2d", EuclideanSpace(_BOX * 2), PointRobot(), 2, OriginalLayouts(C2D_SIZES), exact_reference=True
    ),
    "c3d": lambda: EnvSpec("c3d", EuclideanSpace(_BOX * 3), PointRobot(), 3, C3DLayouts(), blocks=10),
    "rigid": lambda: EnvSpec("rigid", SE2Space(_BOX * 2, radius=_RIGID.radius), _RIGID, 2, OriginalLayouts()),
    # MotionBenchMaker's Franka Panda (the paper's Baxter is not installable): joint vectors
    # within the model's limits, obstacles in metres in the base frame.
    "arm7": lambda: _panda("arm7", ArmScenes()),
    # The same Panda in scenes of MotionBenchMaker's seven families, with MBM's queries
    # (mpnet.envs.mbm.generator): the training and test data for MBM's 700 problems (issue 26).
    "panda_mbm": _panda_mbm,
}


@cache
def _built(name: str) -> EnvSpec:
    return _BUILDERS[name]()


class _Registry(Mapping[str, EnvSpec]):
    """The envs by name: names known at once, each EnvSpec built on first access, then the same object."""

    def __getitem__(self, name: str) -> EnvSpec:
        if name not in _BUILDERS:
            raise KeyError(name)
        return _built(name)

    def __iter__(self) -> Iterator[str]:
        return iter(_BUILDERS)

    def __len__(self) -> int:
        return len(_BUILDERS)


SPECS: Mapping[str, EnvSpec] = _Registry()


def get_spec(name: str) -> EnvSpec:
    try:
        return SPECS[name]
    except KeyError:
        raise KeyError(f"unknown env {name!r}; choices: {', '.join(sorted(SPECS))}") from None
