"""`python -m harness.export_weights +env=ENV [scale=quick] [export_dir=DIR]`: the trained
networks of ENV at this scale (from the cache, trained first if missing) as a pretrained
set: encoder and Pnet as float32 arrays plus the models' content key, by default into the
package's mpnet/data_files/pretrained/ENV-SCALE, which `python -m harness` uses when its
cache lacks the models of that key."""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig

from harness.cli import run_hydra, user_errors


@hydra.main(version_base="1.3", config_path="../conf", config_name="export")
@user_errors
def main(cfg: DictConfig) -> None:
    from harness.artifacts import ensure_models, models_key_config
    from harness.config import check_config
    from harness.fit import PNET_FILE
    from mpnet.models.pretrained import SHIPPED, export_pretrained

    check_config(cfg)
    folder, manifest, _ = ensure_models(cfg, progress=bool(cfg.progress))
    key_config = models_key_config(cfg)
    if manifest["config"] != key_config:  # by construction; a mismatch would ship weights under a wrong key
        raise AssertionError(f"{folder}: manifest config differs from the current config's")
    out = Path(cfg.export_dir or SHIPPED) / f"{cfg.env.name}-{cfg.scale.name}"
    meta = export_pretrained(folder / PNET_FILE, out, manifest["key"], key_config)
    print(f"exported: {out} ({meta['weights']['bytes'] / 1e6:.1f} MB, key {meta['key']}, from {folder})")


if __name__ == "__main__":
    run_hydra(main, required=("env",))
