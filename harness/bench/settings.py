"""What decides a run's results, so that a resumed run can be held to it.

Every config value counts except those that only change how a run is carried out (where
the cache lives, logging switches, processes, Hydra's own); the problem file counts by its
content, not its path.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

# Keys that change how a run is carried out, never what it finds.
NOT_RESULTS = ("rerun", "resume", "progress", "cache_dir", "jobs", "hydra", "shard", "shards", "merge")


def file_digest(path: str | Path) -> str:
    """sha256 of a problem file; of a folder of them (MotionBenchMaker's), over every file's
    relative path and sha256, in sorted order."""
    path = Path(path)
    if not path.is_dir():
        with open(path, "rb") as f:
            return "sha256:" + hashlib.file_digest(f, "sha256").hexdigest()
    h = hashlib.sha256()
    for f in sorted(p for p in path.rglob("*") if p.is_file()):
        with open(f, "rb") as fh:
            h.update(str(f.relative_to(path)).encode() + b"\0" + hashlib.file_digest(fh, "sha256").digest())
    return "sha256:" + h.hexdigest()


def _flatten(value, prefix: str, out: dict) -> None:
    if isinstance(value, dict) and value:
        for k, v in value.items():
            _flatten(v, f"{prefix}.{k}" if prefix else str(k), out)
    else:
        out[prefix] = value


def run_settings(cfg: DictConfig) -> dict:
    """Dotted key -> value for every config value that decides results."""
    tree = OmegaConf.to_container(cfg, resolve=True)
    for key in NOT_RESULTS:
        tree.pop(key, None)
    if tree.get("problems"):
        tree["problems"] = file_digest(tree["problems"])
    out: dict = {}
    _flatten(tree, "", out)
    return out
