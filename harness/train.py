"""`python -m harness.train +env=ENV [scale=S]`: train Enet (contractive autoencoder on
point clouds) and then Pnet (on expert waypoint pairs, both directions) with Lightning."""

from __future__ import annotations

import json

import hydra
from omegaconf import DictConfig

from harness.core.cli import run_hydra, user_errors


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
@user_errors
def main(cfg: DictConfig) -> None:
    from harness.artifacts.ensure import ensure_models
    from harness.core.kernels import use_kernel_cache
    from harness.core.settings import settings_of

    run = settings_of(cfg)
    use_kernel_cache(run.cache_dir)  # before the first kernel runs (harness.core.kernels)
    folder, manifest, built = ensure_models(run, progress=run.progress)
    print(f"{'trained' if built else 'cached'}: {folder}")
    print(json.dumps(manifest["fit"], indent=2))


if __name__ == "__main__":
    run_hydra(main, required=("env",))
