"""MPNet assembled from a models folder, behind the same Planner protocol as OMPL's.

conf/planner/mpnet_nr.yaml, mpnet_hr.yaml and the ablations mpnet_*_*.yaml make an
:class:`MPNetSettings` (every setting checked when it is made, so a bad one costs no
training); the app then calls its ``build`` with the resolved networks' folder, the env,
the run's seed and the workspace cloud, and gets the planner in one step."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpnet.envs.spec import EnvSpec
from mpnet.models.checkpoint import load_pnet_numpy
from mpnet.models.numpy_nets import NumpyPnet
from mpnet.planners.classical import ALGORITHMS, OmplPlanner
from mpnet.planners.neural import MPNetPlanner, check_settings
from mpnet.settings import MPNetOptions

PNET_FILE = "pnet.ckpt"


@dataclass(frozen=True, kw_only=True)
class MPNetSettings(MPNetOptions):
    """MPNet (NR, or HR with the OMPL planner `fallback`), as a config gives it, checked: the
    settings and their defaults are mpnet.settings' (MPNetOptions), the name the config's. proposal,
    encoding and dropout ablate one piece each (Pnet's proposals, the workspace code Pnet
    sees, Pnet's dropout at planning time); replanning="forgiving" is CMPNet's replanning
    (MPNetPlanner)."""

    name: str

    def __post_init__(self):
        check_settings(self.name, **self.shared(), clip=self.clip)
        if self.hybrid and self.fallback not in ALGORITHMS:
            raise ValueError(
                f"config key planner.fallback: unknown OMPL algorithm {self.fallback!r}; "
                f"choices: {', '.join(ALGORITHMS)}"
            )
        if self.steer_steps is not None:
            object.__setattr__(self, "steer_steps", tuple(self.steer_steps))
        if not isinstance(self.compiled, bool):
            raise ValueError(f"config key planner.compiled: expected true or false, got {self.compiled!r}")
        if self.compiled and self.steer_steps is not None:
            raise ValueError(
                "config key planner.compiled: the compiled planner runs continuous steerTo "
                "(steer_steps: null), or set planner.compiled=false"
            )

    def check_env(self, env: EnvSpec, collision: str | None = None) -> None:
        """What these settings need of the env (ValueError naming the key): the compiled loop,
        kernels for the env's checker."""
        if self.compiled:
            from mpnet.planners.compiled.planner import supports

            if not supports(env, collision):
                raise ValueError(
                    f"config key planner.compiled: env {env.name}'s {collision or 'default'} checker has no "
                    f"compiled kernels (each env's default checker has): set planner.compiled=false for the numpy loop"
                )

    def build(
        self, models_dir: Path, env: EnvSpec, seed: int, cloud: Callable, collision: str | None = None
    ) -> MPNetPlanner:
        """The planner on the networks in models_dir; cloud(workspace) is the workspace's
        point cloud as training drew it; collision the checkers' backend (None: the robot's
        default)."""
        self.check_env(env, collision)
        encode, pnet_step = load_pnet_numpy(Path(models_dir) / PNET_FILE)
        return self.assemble(encode, pnet_step, env, seed, cloud)

    def assemble(
        self, encode: Callable, pnet_step: NumpyPnet, env: EnvSpec, seed: int, cloud: Callable
    ) -> MPNetPlanner:
        """The planner on these numpy networks (build's second half; the env already checked)."""
        if self.encoding == "zeros":
            code = np.zeros(pnet_step.in_dim - 2 * pnet_step.state_dim, np.float32)
            encode, cloud = (lambda _cloud: code), (lambda _ws: None)
        space, dropout = env.space, self.dropout
        canonical = space.clip if self.clip else space.wrap

        def step(z, x, goal, rng):
            return canonical(np.asarray(pnet_step(z, x, goal, rng if dropout else None), float))

        # The fallback's own partial paths are not MPNet's: never copied (it may fail and restart often).
        fallback = OmplPlanner(self.fallback, self.fallback, keep_partial=False) if self.hybrid else None
        if self.compiled:
            from mpnet.planners.compiled.planner import CompiledMPNetPlanner

            return CompiledMPNetPlanner(
                self.name,
                encode,
                pnet_step,
                cloud,
                self.clip,
                hybrid=self.hybrid,
                seed=seed,
                fallback=fallback,
                **self.shared(),
            )
        return MPNetPlanner(
            self.name, encode, step, cloud, hybrid=self.hybrid, seed=seed, fallback=fallback, **self.shared()
        )


def from_checkpoint(
    models_dir: Path, env: EnvSpec, seed: int, cloud: Callable, collision: str | None = None, **settings
) -> MPNetPlanner:
    """MPNet on the networks in models_dir, its settings as MPNetSettings takes them."""
    return MPNetSettings(**settings).build(models_dir, env, seed, cloud, collision)
