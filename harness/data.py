"""`python -m harness.data +env=ENV [scale=S]`: build (or find) the env's training dataset.

Sharded over a cluster (docs/cluster.md): `shards=N -m shard=range(0,N)`
plans each shard's expert paths into the cache's partial folder of the dataset's content
key; then `merge=true` assembles the one dataset from them, planning nothing.
"""

from __future__ import annotations

import json
import sys
from typing import TYPE_CHECKING

import hydra
from omegaconf import DictConfig

from harness.core.cli import RunRefused, run_hydra, user_errors

if TYPE_CHECKING:
    from harness.core.settings import RunSettings


def _missing_shards(e, shards: int) -> str:
    if shards > 1:
        names = sorted({k % shards for k in e.missing})
        return f"shard{'s' if len(names) > 1 else ''} {', '.join(map(str, names))} of shards={shards} not finished"
    return f"chunk{'s' if len(e.missing) > 1 else ''} {', '.join(map(str, e.missing))} not planned"


def _shard(run: RunSettings) -> None:
    from harness.artifacts.ensure import dataset_shard

    folder, paths = dataset_shard(run, run.shard, run.shards, progress=run.progress)
    if paths is None:
        print(f"cached: {folder}")
        return
    print(
        f"shard {run.shard}/{run.shards}: {len(paths)} expert paths over {len(set(paths.workspace.tolist()))} "
        f"workspaces, {paths.seconds:.1f} s planning, in {folder}"
    )


def _build(run: RunSettings) -> None:
    from harness.artifacts.ensure import ensure_dataset, ensure_testset
    from mpnet.data.expert import MissingChunks

    try:
        folder, m, built = ensure_dataset(run, progress=run.progress, plan=not run.merge)
    except MissingChunks as e:
        raise RunRefused(
            f"config key merge: {len(e.missing)} of {e.chunks} chunks of expert paths missing "
            f"({_missing_shards(e, run.shards)}); run them, or drop merge=true to plan them here"
        ) from None
    testset = ensure_testset(run, progress=run.progress)  # not sharded: see docs/cluster.md
    print(f"{'built' if built else 'cached'}: {folder}")
    print(f"test set: {len(testset.workspaces)} workspaces, {len(testset.queries)} queries ({', '.join(run.splits)})")
    print(
        f"{m['expert']['paths']} expert paths over {m['sizes']['train_ids'][0]} workspaces, "
        f"{m['sizes']['ae_clouds'][0]} autoencoder clouds, {m['bytes'] / 1e6:.1f} MB"
    )
    print(json.dumps(m["expert"], indent=2))
    stops = m["expert"].get("runs_ended_by_clock")
    if stops:  # the expert's paths then depend on the machine's speed and load (ExpertPaths.clock_stops)
        print(
            f"warning: {stops} expert runs ended on their clock (env.expert.max_seconds), not their own count: "
            "these paths depend on this machine's speed and load, and a build elsewhere may keep others",
            file=sys.stderr,
        )


@hydra.main(version_base="1.3", config_path="../conf", config_name="data")
@user_errors
def main(cfg: DictConfig) -> None:
    from harness.core.kernels import use_kernel_cache
    from harness.core.settings import settings_of

    run = settings_of(cfg)
    use_kernel_cache(run.cache_dir)  # before the first kernel runs (harness.core.kernels)
    if run.shard is not None:
        _shard(run)
    else:
        _build(run)


if __name__ == "__main__":
    run_hydra(main, required=("env",))
