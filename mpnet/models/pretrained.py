"""Pretrained networks in a compact form that ships with the package: what a planner
needs (Enet's encoder and Pnet, float32, bit for bit) without the decoder or the
optimizer's state, and the content key of the models artifact they were exported from,
so that they stand in for exactly that artifact and no other.

A set is a folder: weights.npz (the state dict's arrays) and meta.json (format, key,
key config, the checkpoint's hyperparameters, the weights' size and sha256)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mpnet.data.store import SET_META as META
from mpnet.data.store import ArtifactError, file_checksum, find_set, read_set_meta
from mpnet.models.checkpoint import CheckpointError, _load

FORMAT = "mpnet-bench/pretrained@1"
WEIGHTS = "weights.npz"
SHIPPED = Path(__file__).resolve().parents[1] / "data_files" / "pretrained"  # the package's sets
_PLANNER_PARTS = ("pnet.", "encoder.")  # what load_pnet_checkpoint reads


def export_pretrained(
    pnet_ckpt: Path,
    out: Path,
    key: str,
    key_config: dict,
    training_paths: int | None = None,
    built: dict | None = None,
) -> dict:
    """Write a Pnet checkpoint's planner part into folder `out`; returns its meta.
    training_paths: how many expert paths it was trained on, where known (kept in the meta
    for the runs that plan on the set: their learning curve's size). built: how the data and
    the networks were built (wall time, revision, machine, from their manifests): the file
    a quoted build or training time comes from."""
    hp, state = _load(pnet_ckpt, "cpu")
    arrays = {k: v.numpy() for k, v in state.items() if k.startswith(_PLANNER_PARTS)}
    odd = [k for k, a in arrays.items() if a.dtype != np.float32]
    if odd:
        raise CheckpointError(f"{pnet_ckpt}: not float32: {', '.join(odd)}")
    out.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out / WEIGHTS, **arrays)
    meta = {
        "format": FORMAT,
        "key": key,
        "config": key_config,
        "hyper_parameters": hp,
        "weights": file_checksum(out / WEIGHTS),
        **({"training_paths": int(training_paths)} if training_paths is not None else {}),
        **({"built": built} if built else {}),
    }
    (out / META).write_text(json.dumps(meta, indent=2, sort_keys=True) + "\n")
    return meta


def read_meta(folder: Path) -> dict:
    try:
        return read_set_meta(folder, FORMAT)
    except ArtifactError as e:
        raise CheckpointError(str(e)) from None


def find_pretrained(key: str, root: Path = SHIPPED) -> Path | None:
    """The set under root exported from the models artifact with this content key."""
    return find_set(root, FORMAT, key)


def write_checkpoint(folder: Path, path: Path) -> dict:
    """The set as a checkpoint that load_pnet_checkpoint reads (its weights verified
    against meta.json first); returns the meta."""
    meta = read_meta(folder)
    got = file_checksum(folder / WEIGHTS)
    if got != meta["weights"]:
        raise CheckpointError(f"{folder / WEIGHTS}: {got} differs from {folder / META}'s {meta['weights']}")
    import torch  # here: importing this module (the cache's lookup of a shipped set) must not cost it

    with np.load(folder / WEIGHTS) as z:
        state = {k: torch.from_numpy(z[k].copy()) for k in z.files}
    torch.save({"hyper_parameters": meta["hyper_parameters"], "state_dict": state}, path)
    return meta


__all__ = ["FORMAT", "SHIPPED", "export_pretrained", "find_pretrained", "read_meta", "write_checkpoint"]
