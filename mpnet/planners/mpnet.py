"""MPNet assembled from a models folder, behind the same Planner protocol as OMPL's
(conf/planner/mpnet_nr.yaml, mpnet_hr.yaml and the ablations mpnet_*_*.yaml name
`from_checkpoint` with its constructor arguments)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from mpnet.envs.spec import EnvSpec
from mpnet.models.checkpoint import load_pnet_checkpoint
from mpnet.planners.classical import OmplPlanner
from mpnet.planners.neural import MPNetPlanner

PNET_FILE = "pnet.ckpt"


def from_checkpoint(
    models_dir: Path | Callable[[], Path],
    env: EnvSpec,
    seed: int,
    cloud: Callable,
    *,
    name: str,
    hybrid: bool = False,
    max_steps: int = 80,
    replan_steps: int = 50,
    replan_rounds: int = 10,
    steer_steps=None,
    fallback: str = "rrt_star",
    fallback_restart_s: float | None = 0.5,
    proposal: str = "pnet",
    straight_step: float = 0.1,
    encoding: str = "cloud",
    dropout: bool = True,
    replanning: str = "original",
) -> MPNetPlanner:
    """MPNet (NR, or HR with the OMPL planner `fallback`) on the networks in models_dir.

    models_dir may be a callable that returns the folder (building the networks on first
    use): the settings are checked before it is called, so a bad one costs no training.
    cloud(workspace) is the workspace's point cloud as training drew it. proposal, encoding
    and dropout ablate one piece each (Pnet's proposals, the workspace code Pnet sees,
    Pnet's dropout at planning time); replanning="forgiving" is CMPNet's replanning
    (MPNetPlanner).
    """
    planner = MPNetPlanner(
        name,
        None,
        None,
        None,
        hybrid=hybrid,
        max_steps=max_steps,
        replan_steps=replan_steps,
        replan_rounds=replan_rounds,
        seed=seed,
        steer_steps=steer_steps,
        proposal=proposal,
        straight_step=straight_step,
        fallback_restart_s=fallback_restart_s,
        encoding=encoding,
        dropout=dropout,
        replanning=replanning,
    )
    # The fallback's own partial paths are not MPNet's: never copied (it may fail and restart often).
    planner.fallback = OmplPlanner(fallback, fallback, keep_partial=False) if hybrid else None
    folder = Path(models_dir() if callable(models_dir) else models_dir)
    encode, pnet_step = load_pnet_checkpoint(folder / PNET_FILE).to_numpy()
    if encoding == "zeros":
        code = np.zeros(pnet_step.in_dim - 2 * pnet_step.state_dim, np.float32)
        encode, cloud = (lambda _cloud: code), (lambda _ws: None)
    space = env.space

    def step(z, x, goal, rng):
        return space.wrap(np.asarray(pnet_step(z, x, goal, rng if dropout else None), float))

    planner.encode, planner.step, planner.cloud = encode, step, cloud
    return planner
