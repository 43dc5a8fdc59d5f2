"""Issue 42: Pnet's first step on its own training scenes, by MotionBenchMaker family. For every
expert path of a panda_mbm dataset, resampled as the env's recipe trains on it (0.5 rad), Pnet's
proposal from the path's start toward its goal (fwd) and from its goal toward its start (bwd),
without dropout: is it a valid state, is the motion to it free (the sphere checker), and how far
is it from the expert's next waypoint (rad). Where NR loses to random proposals (one family,
table_under_pick) this says whether Pnet's first step already fails on the scenes it was trained on.

    PYTHONPATH=<checkout> python docs/research/panda_mbm_first_step.py DATA_DIR [--nets SET_OR_CKPT]
        [--out reports/archive/panda_mbm_first_step]

DATA_DIR: a panda_mbm dataset folder (cache_dir/data/<key>, data.npz and manifest.json); --nets:
the networks (a shipped set folder or a pnet checkpoint; default: the shipped panda_mbm-quick set).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from harness.core.provenance import generated_by, machine_info
from mpnet.data.dataset import load_dataset
from mpnet.envs.mbm.generator import FAMILY_ORDER
from mpnet.envs.scenes.generators import make_workspaces
from mpnet.envs.specs import get_spec
from mpnet.models.checkpoint import load_pnet_numpy
from mpnet.models.datamodule import resample_path
from mpnet.models.pretrained import SHIPPED, write_checkpoint

STEP = 0.5  # the env's recipe's waypoint_step (conf/env/panda_mbm.yaml)


def first_steps(data_dir: Path, nets: Path) -> pd.DataFrame:
    manifest = json.loads((data_dir / "manifest.json").read_text())
    ds = load_dataset(data_dir, manifest)
    spec = get_spec("panda_mbm")
    with tempfile.TemporaryDirectory() as tmp:
        if nets.is_dir():
            write_checkpoint(nets, Path(tmp) / "pnet.ckpt")
            nets = Path(tmp) / "pnet.ckpt"
        enet, pnet = load_pnet_numpy(nets)
    wss = make_workspaces(spec, [int(i) for i in ds.train_ids], "train", manifest["config"]["data_seed"])
    rows = []
    for row, ws in enumerate(wss):
        z = enet.encode(ds.train_clouds[row])
        checker = spec.make_checker(ws)
        family = FAMILY_ORDER[int(ws.id) % len(FAMILY_ORDER)]
        for i in np.flatnonzero(ds.paths.workspace == row):
            path = ds.paths.path(i)
            for way, p in (("fwd", path), ("bwd", path[::-1])):
                r = resample_path(p, STEP, spec.space)
                x, goal, target = r[0], r[-1], r[1]
                y = pnet.step(z, x, goal)
                valid = checker.is_valid(y.tolist())
                rows.append(
                    {
                        "family": family,
                        "direction": way,
                        "valid": valid,
                        "motion_free": valid and checker.motion_valid(x.tolist(), y.tolist()),
                        "error_rad": float(np.linalg.norm(y - target)),
                        "expert_step_rad": float(np.linalg.norm(target - x)),
                        "pnet_step_rad": float(np.linalg.norm(y - x)),
                    }
                )
    return pd.DataFrame(rows)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("data_dir", type=Path)
    ap.add_argument("--nets", type=Path, default=SHIPPED / "panda_mbm-quick")
    ap.add_argument("--out", type=Path, default=Path("reports/archive/panda_mbm_first_step"))
    args = ap.parse_args()
    df = first_steps(args.data_dir, args.nets)
    table = (
        df.groupby(["family", "direction"])
        .agg(
            paths=("valid", "size"),
            valid=("valid", "mean"),
            motion_free=("motion_free", "mean"),
            error_median_rad=("error_rad", "median"),
            expert_step_median_rad=("expert_step_rad", "median"),
            pnet_step_median_rad=("pnet_step_rad", "median"),
        )
        .reset_index()
    )
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "first_step.csv", index=False)
    command = f"python docs/research/panda_mbm_first_step.py {args.data_dir} --nets {args.nets}"
    lines = [
        "# Pnet's first step on its own training scenes, by family",
        "",
        generated_by(command, machine_info()),
        "",
        "Each expert path of the dataset resampled at 0.5 rad (the env's recipe); Pnet's proposal from its start "
        "toward its goal (fwd) and from its goal toward its start (bwd), without dropout; valid: the proposal is a "
        "valid state; motion free: and the motion to it too (the sphere checker); error: distance to the expert's "
        "next waypoint (rad, median).",
        "",
        "| family | direction | paths | valid | motion free | error (rad) | expert step (rad) | Pnet step (rad) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
        *(
            f"| {r.family} | {r.direction} | {r.paths} | {r.valid:.1%} | {r.motion_free:.1%} | "
            f"{r.error_median_rad:.3f} | {r.expert_step_median_rad:.3f} | {r.pnet_step_median_rad:.3f} |"
            for r in table.itertuples()
        ),
        "",
    ]
    (args.out / "README.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
