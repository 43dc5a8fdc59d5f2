"""MPNet planners for the bench: the trained networks from the model artifact, behind
the same Planner protocol as OMPL's (see conf/planner/mpnet_nr.yaml, mpnet_hr.yaml)."""
from __future__ import annotations

import numpy as np

from mpnet.envs.workspace import EnvSpec, wrap_angle
from mpnet.planners.classical import OmplPlanner
from mpnet.planners.neural import MPNetPlanner, workspace_cloud


def mpnet_planner(name: str, hybrid: bool, max_steps: int, replan_steps: int, replan_rounds: int,
                  fallback: str, steer_steps=None, *, models_folder, spec: EnvSpec, points_per_block: int, data_seed: int,
                  seed: int) -> MPNetPlanner:
    """MPNet (NR, or HR with OMPL `fallback`) on the networks in models_folder."""
    from mpnet.models.checkpoint import load_pnet_checkpoint

    encode, pnet_step = load_pnet_checkpoint(models_folder / "pnet.ckpt").to_numpy()

    def step(z, x, goal, rng):
        nxt = np.asarray(pnet_step(z, x, goal, rng), float)
        if spec.is_se2:
            nxt[2] = wrap_angle(nxt[2])
        return nxt

    return MPNetPlanner(name, encode, step, workspace_cloud(points_per_block * spec.blocks, data_seed),
                        hybrid=hybrid, max_steps=max_steps, replan_steps=replan_steps, replan_rounds=replan_rounds,
                        seed=seed, fallback=OmplPlanner(fallback, fallback) if hybrid else None,
                        steer_steps=steer_steps)

