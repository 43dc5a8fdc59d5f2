"""`python -m harness.data +env=ENV [scale=S]`: build (or find) the env's training dataset."""

from __future__ import annotations

import json

import hydra
from omegaconf import DictConfig

from harness.cli import run_hydra, user_errors


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
@user_errors
def main(cfg: DictConfig) -> None:
    from harness.artifacts import ensure_dataset, ensure_testset

    testset = ensure_testset(cfg, progress=bool(cfg.progress))
    folder, m, built = ensure_dataset(cfg, progress=bool(cfg.progress))
    print(f"{'built' if built else 'cached'}: {folder}")
    print(f"test set: {len(testset.workspaces)} workspaces, {len(testset.queries)} queries ({', '.join(cfg.splits)})")
    print(
        f"{m['expert']['paths']} expert paths over {m['sizes']['train_ids'][0]} workspaces, "
        f"{m['sizes']['ae_clouds'][0]} autoencoder clouds, {m['bytes'] / 1e6:.1f} MB"
    )
    print(json.dumps(m["expert"], indent=2))


if __name__ == "__main__":
    run_hydra(main, required=("env",))
