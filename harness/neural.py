"""MPNet planners for the bench: the trained networks from the model artifact, behind
the same Planner protocol as OMPL's (see conf/planner/mpnet_nr.yaml, mpnet_hr.yaml, and
the ablations conf/planner/mpnet_nr_*.yaml)."""
from __future__ import annotations

import numpy as np

from mpnet.envs.workspace import EnvSpec, wrap_angle
from mpnet.planners.classical import OmplPlanner
from mpnet.planners.neural import PROPOSALS, MPNetPlanner, workspace_cloud

ENCODINGS = ("cloud", "zeros")
BASE_NAMES = ("mpnet_nr", "mpnet_hr")


def ablation_of(proposal: str = "pnet", encoding: str = "cloud", dropout: bool = True) -> str:
    """'' for MPNet as the paper, else what is ablated (e.g. 'proposal=random')."""
    changed = [f"proposal={proposal}"] if proposal != "pnet" else []
    changed += [f"encoding={encoding}"] if encoding != "cloud" else []
    changed += ["dropout=false"] if not dropout else []
    return ", ".join(changed)


def check_ablation(name: str, proposal: str = "pnet", encoding: str = "cloud", dropout: bool = True) -> None:
    """ValueError naming the config key of a bad ablation setting, or of an ablation that
    would be logged under MPNet's own name."""
    if proposal not in PROPOSALS:
        raise ValueError(f"config key planner.proposal: expected one of {', '.join(PROPOSALS)}, got {proposal!r}")
    if encoding not in ENCODINGS:
        raise ValueError(f"config key planner.encoding: expected one of {', '.join(ENCODINGS)}, got {encoding!r}")
    if not isinstance(dropout, bool):
        raise ValueError(f"config key planner.dropout: expected true or false, got {dropout!r}")
    ablated = ablation_of(proposal, encoding, dropout)
    if ablated and name in BASE_NAMES:
        raise ValueError(f"config key planner.name: an ablation ({ablated}) is logged under its own name, "
                         f"not {name!r}: use its config (+planner=mpnet_nr_random, ...) or set planner.name")


def mpnet_planner(name: str, hybrid: bool, max_steps: int, replan_steps: int, replan_rounds: int,
                  fallback: str, steer_steps=None, proposal: str = "pnet", encoding: str = "cloud",
                  dropout: bool = True, straight_step: float = 0.1, fallback_restart_s: float | None = 0.5, *,
                  models_folder, spec: EnvSpec,
                  points_per_block: int, data_seed: int, seed: int) -> MPNetPlanner:
    """MPNet (NR, or HR with OMPL `fallback`) on the networks in models_folder.

    proposal, encoding and dropout ablate one piece each (Pnet's proposals, the workspace
    code Pnet sees, Pnet's dropout at planning time); an ablation is logged under its own
    planner name, so the report never mixes it with MPNet.
    """
    from mpnet.models.checkpoint import load_pnet_checkpoint

    check_ablation(name, proposal, encoding, dropout)

    encode, pnet_step = load_pnet_checkpoint(models_folder / "pnet.ckpt").to_numpy()
    cloud = workspace_cloud(points_per_block * spec.blocks, data_seed)
    if encoding == "zeros":
        code = np.zeros(pnet_step.in_dim - 2 * pnet_step.state_dim, np.float32)
        encode, cloud = (lambda _cloud: code), (lambda _ws: None)

    def step(z, x, goal, rng):
        nxt = np.asarray(pnet_step(z, x, goal, rng if dropout else None), float)
        if spec.is_se2:
            nxt[2] = wrap_angle(nxt[2])
        return nxt

    return MPNetPlanner(name, encode, step, cloud,
                        hybrid=hybrid, max_steps=max_steps, replan_steps=replan_steps, replan_rounds=replan_rounds,
                        seed=seed, fallback=OmplPlanner(fallback, fallback) if hybrid else None,
                        steer_steps=steer_steps, proposal=proposal, straight_step=straight_step,
                        fallback_restart_s=fallback_restart_s)
