"""The fixed geometry of each environment (DESIGN §4)."""
from __future__ import annotations

import math

from mpnet.envs.workspace import ROBOT_RECTANGLE, EnvSpec

SPECS: dict[str, EnvSpec] = {
    "s2d": EnvSpec("s2d", 2, 2, ((-20.0, 20.0),) * 2),
    "c2d": EnvSpec("c2d", 2, 2, ((-20.0, 20.0),) * 2),
    "c3d": EnvSpec("c3d", 3, 3, ((-20.0, 20.0),) * 3, blocks=10),
    "rigid": EnvSpec(
        "rigid", 3, 2, ((-20.0, 20.0), (-20.0, 20.0), (-math.pi, math.pi)),
        robot=ROBOT_RECTANGLE, robot_size=(2.0, 5.0),
    ),
}


def get_spec(name: str) -> EnvSpec:
    try:
        return SPECS[name]
    except KeyError:
        raise KeyError(f"unknown env {name!r}; choices: {', '.join(sorted(SPECS))}") from None
