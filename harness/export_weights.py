"""`python -m harness.export_weights +env=ENV [scale=quick] [+planner=P] [export_dir=DIR]`: what
a fresh clone needs to plan ENV at this scale at once, from the cache (built first if missing):
the trained networks as a pretrained set (encoder and Pnet as float32 arrays plus the
models' content key) into DIR/pretrained/ENV-SCALE, and the test set into
DIR/testsets/ENV-SCALE. DIR defaults to the package's mpnet/data_files, whose sets
`python -m harness` uses when its cache lacks the artifacts of their keys.

A planner whose networks are not the env's (another models key: `+planner=mpnet_nr_paper` on
panda_mbm, the paper's recipe) exports its own set beside the env's, named by its networks' tags
as its runs are labelled (ENV-SCALE+paper_recipe): a shared name would replace the env's set.
Networks that differ from the env's only in options no tag names are refused, before training."""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf, open_dict

from harness.core.cli import UsageError, run_hydra, user_errors


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
    key_config = models_key_config(run)
    name = f"{run.env.name}-{run.scale}"
    set_name = _set_name(cfg, run, name)  # before training: a set that cannot be named is not built
    folder, manifest, _ = ensure_models(run, progress=run.progress)
    if manifest["config"] != key_config:  # by construction; a mismatch would ship weights under a wrong key
        raise AssertionError(f"{folder}: manifest config differs from the current config's")
    root = Path(cfg.export_dir) if cfg.export_dir else SHIPPED.parent
    out = root / SHIPPED.name / set_name
    paths = training_paths(run)  # before the export: it may read the set being replaced
    built = {"models": _built(manifest), "data": _built(_data_manifest(run, key_config))}
    meta = export_pretrained(folder / PNET_FILE, out, manifest["key"], key_config, training_paths=paths, built=built)
    print(f"exported: {out} ({meta['weights']['bytes'] / 1e6:.1f} MB, key {meta['key']}, from {folder})")
    ts_folder, ts_manifest, _ = ensure_testset_artifact(run, progress=run.progress)
    ts_out = root / SHIPPED_TESTSETS.name / name
    ts_meta = export_testset(ts_folder, ts_manifest, ts_out)
    size = sum(f["bytes"] for f in ts_meta["files"].values())
    print(f"exported: {ts_out} ({size / 1e6:.2f} MB, key {ts_meta['key']}, from {ts_folder})")


def _set_name(cfg: DictConfig, run, name: str) -> str:
    """`name` (ENV-SCALE) for the env's own networks, whatever the planner whose options change
    nothing; NAME+TAGS, the tags of the planner's networks as its runs are labelled, for other
    networks. UsageError where they differ in options no tag names."""
    from harness.core.config import model_params
    from harness.log.facts import network_variant

    bare = cfg.copy()
    with open_dict(bare):
        bare.pop("planner", None)
    if model_params(bare) == run.models:  # the dataset's params take no planner: the networks' decide
        return name
    networks = OmegaConf.select(cfg, "planner.networks")
    tags = network_variant(OmegaConf.to_container(networks, resolve=True) if networks is not None else None)
    if not tags:
        raise UsageError(
            f"planner.networks: {cfg.planner.name}'s networks differ from the env's (set {name}) in options no "
            "tag names, so their set would take the env's name: export the env's networks or a labelled recipe"
        )
    return "+".join([name, *tags])


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
