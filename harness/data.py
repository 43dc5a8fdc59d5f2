"""`python -m harness.data +env=ENV [scale=S]`: build (or find) the env's training dataset.

Sharded over a cluster (README, "Running on a cluster"): `shards=N -m shard=range(0,N)`
plans each shard's expert paths into the cache's partial folder of the dataset's content
key; then `merge=true` assembles the one dataset from them, planning nothing.
"""

from __future__ import annotations

import json
import sys

import hydra
from omegaconf import DictConfig

from harness.cli import UsageError, run_hydra, user_errors


def _integer(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def check_sharding(cfg: DictConfig) -> None:
    """shard, shards and merge as a user types them: UsageError naming the key."""
    shards, shard, merge = cfg.shards, cfg.shard, cfg.merge
    if not _integer(shards) or shards < 1:
        raise UsageError(f"config key shards: expected an integer >= 1, got {shards!r}")
    if shard is not None and (not _integer(shard) or not 0 <= shard < shards):
        raise UsageError(f"config key shard: expected an integer in [0, shards={shards}), got {shard!r}")
    if not isinstance(merge, bool):
        raise UsageError(f"config key merge: expected true or false, got {merge!r}")
    if merge and shard is not None:
        raise UsageError(f"config key merge: merge=true assembles every shard; drop shard={shard}")


def _missing_shards(e, shards: int) -> str:
    if shards > 1:
        names = sorted({k % shards for k in e.missing})
        return f"shard{'s' if len(names) > 1 else ''} {', '.join(map(str, names))} of shards={shards} not finished"
    return f"chunk{'s' if len(e.missing) > 1 else ''} {', '.join(map(str, e.missing))} not planned"


def _shard(cfg: DictConfig) -> None:
    from harness.artifacts import dataset_shard

    folder, paths = dataset_shard(cfg, int(cfg.shard), int(cfg.shards), progress=bool(cfg.progress))
    if paths is None:
        print(f"cached: {folder}")
        return
    print(
        f"shard {cfg.shard}/{cfg.shards}: {len(paths)} expert paths over {len(set(paths.workspace.tolist()))} "
        f"workspaces, {paths.seconds:.1f} s planning, in {folder}"
    )


def _build(cfg: DictConfig) -> None:
    from harness.artifacts import ensure_dataset, ensure_testset
    from mpnet.data.expert import MissingChunks

    try:
        folder, m, built = ensure_dataset(cfg, progress=bool(cfg.progress), plan=not cfg.merge)
    except MissingChunks as e:
        raise UsageError(
            f"config key merge: {len(e.missing)} of {e.chunks} chunks of expert paths missing "
            f"({_missing_shards(e, int(cfg.shards))}); run them, or drop merge=true to plan them here"
        ) from None
    testset = ensure_testset(cfg, progress=bool(cfg.progress))  # not sharded: see the README
    print(f"{'built' if built else 'cached'}: {folder}")
    print(f"test set: {len(testset.workspaces)} workspaces, {len(testset.queries)} queries ({', '.join(cfg.splits)})")
    print(
        f"{m['expert']['paths']} expert paths over {m['sizes']['train_ids'][0]} workspaces, "
        f"{m['sizes']['ae_clouds'][0]} autoencoder clouds, {m['bytes'] / 1e6:.1f} MB"
    )
    print(json.dumps(m["expert"], indent=2))


@hydra.main(version_base="1.3", config_path="../conf", config_name="data")
@user_errors
def main(cfg: DictConfig) -> None:
    from harness.config import check_config

    try:
        check_config(cfg)
        check_sharding(cfg)
        if cfg.shard is not None:
            _shard(cfg)
        else:
            _build(cfg)
    except UsageError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    run_hydra(main, required=("env",))
