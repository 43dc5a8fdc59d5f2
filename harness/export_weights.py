"""`python -m harness.export_weights +env=ENV [scale=quick] [+planner=P] [export_dir=DIR]`: what
a fresh clone needs to plan ENV at this scale at once, from the cache (built first if missing):
the trained networks as a pretrained set (encoder and Pnet as float32 arrays plus the
models' content key) into DIR/pretrained/ENV-SCALE, and the test set into
DIR/testsets/ENV-SCALE. DIR defaults to the package's mpnet/data_files, whose sets
`python -m harness` uses when its cache lacks the artifacts of their keys.

A planner whose networks are not the env's recipe (`+planner=mpnet_nr_paper`: the paper's)
exports its own set, named by its networks' tags (ENV-SCALE+paper_recipe), beside the env's:
a set is found by its models' key, and a shared name would replace the env's set."""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig

from harness.core.cli import run_hydra, user_errors


@hydra.main(version_base="1.3", config_path="../conf", config_name="export")
@user_errors
def main(cfg: DictConfig) -> None:
    from harness.artifacts.ensure import ensure_models, ensure_testset_artifact, models_key_config, training_paths
    from harness.artifacts.fit import PNET_FILE
    from harness.core.settings import settings_of
    from mpnet.data.shipped import SHIPPED as SHIPPED_TESTSETS
    from mpnet.data.shipped import export_testset
    from mpnet.models.pretrained import SHIPPED, export_pretrained

    run = settings_of(cfg)
    folder, manifest, _ = ensure_models(run, progress=run.progress)
    key_config = models_key_config(run)
    if manifest["config"] != key_config:  # by construction; a mismatch would ship weights under a wrong key
        raise AssertionError(f"{folder}: manifest config differs from the current config's")
    name = f"{run.env.name}-{run.scale}"
    root = Path(cfg.export_dir) if cfg.export_dir else SHIPPED.parent
    out = root / SHIPPED.name / "+".join([name, *_recipe_tags(cfg)])
    paths = training_paths(run)  # before the export: it may read the set being replaced
    built = {"models": _built(manifest), "data": _built(_data_manifest(run, key_config))}
    meta = export_pretrained(folder / PNET_FILE, out, manifest["key"], key_config, training_paths=paths, built=built)
    print(f"exported: {out} ({meta['weights']['bytes'] / 1e6:.1f} MB, key {meta['key']}, from {folder})")
    ts_folder, ts_manifest, _ = ensure_testset_artifact(run, progress=run.progress)
    ts_out = root / SHIPPED_TESTSETS.name / name
    ts_meta = export_testset(ts_folder, ts_manifest, ts_out)
    size = sum(f["bytes"] for f in ts_meta["files"].values())
    print(f"exported: {ts_out} ({size / 1e6:.2f} MB, key {ts_meta['key']}, from {ts_folder})")


def _recipe_tags(cfg: DictConfig) -> list[str]:
    """The tags of the planner's own networks, as its logs carry them (none: the env's recipe)."""
    from omegaconf import OmegaConf

    from harness.log.facts import network_variant

    networks = OmegaConf.select(cfg, "planner.networks")
    return network_variant(OmegaConf.to_container(networks, resolve=True) if networks is not None else None)


BUILT_FIELDS = ("build_wall_s", "created_at", "git_rev", "machine")


def _built(manifest: dict | None) -> dict | None:
    """An artifact's build as its manifest says: wall time, when, revision, machine (and, for
    data, the expert paths' count and planning seconds)."""
    if not manifest:
        return None
    out = {k: manifest[k] for k in BUILT_FIELDS if k in manifest}
    expert = manifest.get("expert")
    if isinstance(expert, dict):
        out["expert"] = {k: expert[k] for k in ("paths", "planning_seconds") if k in expert}
    return out


def _data_manifest(run, key_config: dict) -> dict | None:
    """The manifest of the dataset the networks were trained on, when the cache has it."""
    from mpnet.data.store import ArtifactError, read_manifest

    folder = run.cache_dir / "data" / key_config["data"]
    try:
        return read_manifest(folder, folder.name, verify=False)
    except ArtifactError:
        return None


if __name__ == "__main__":
    run_hydra(main, required=("env",))
