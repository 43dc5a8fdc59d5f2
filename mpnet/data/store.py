"""Artifacts on disk: a folder per content key, built once under a file lock, written to
a temporary name and renamed into place, with a manifest that is checked on load.

Concurrent jobs of a sweep that need the same artifact: the first builds it, the others
wait on the lock and then load what it built.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import shutil
import time
import uuid
from collections.abc import Callable
from pathlib import Path

from filelock import FileLock

MANIFEST = "manifest.json"


class ArtifactError(Exception):
    """An artifact on disk is missing pieces or belongs to another config."""


def content_key(config: dict) -> str:
    """A short stable hash of the config that produces an artifact."""
    text = json.dumps(config, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def read_manifest(folder: Path, key: str) -> dict:
    path = folder / MANIFEST
    try:
        manifest = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise ArtifactError(f"{path}: unreadable manifest ({e})") from None
    if manifest.get("key") != key:
        raise ArtifactError(f"{path}: built for key {manifest.get('key')!r}, expected {key!r}")
    missing = [f for f in manifest.get("files", []) if not (folder / f).exists()]
    if missing:
        raise ArtifactError(f"{folder}: missing {', '.join(missing)}")
    return manifest


def partial_dir(root: str | Path, kind: str, config: dict) -> Path:
    """Where a long build of this artifact keeps its finished pieces (e.g. expert paths per
    chunk of workspaces), so that a build cut short resumes: same content key, same pieces.
    `ensure` removes it once the artifact is in place."""
    return Path(root) / kind / f".{content_key({'kind': kind, **config})}.partial"


def ensure(
    root: str | Path,
    kind: str,
    config: dict,
    build: Callable[[Path], dict],
    provenance: Callable[[], dict] | None = None,
) -> tuple[Path, dict, bool]:
    """The artifact of `kind` for `config` under `root`, building it if absent.

    build(tmp_folder) writes the files and returns manifest fields (must include "files");
    provenance() gives further manifest fields, asked for only when building.
    Returns (folder, manifest, built_now)."""
    key = content_key({"kind": kind, **config})
    base = Path(root) / kind
    base.mkdir(parents=True, exist_ok=True)
    folder = base / key
    if folder.exists():
        try:
            return folder, read_manifest(folder, key), False
        except ArtifactError:
            pass  # rebuilt below, under the lock
    with FileLock(str(base / f"{key}.lock")):
        if folder.exists():
            try:
                return folder, read_manifest(folder, key), False
            except ArtifactError:
                shutil.rmtree(folder)
        for stale in base.glob(f".{key}.tmp-*"):  # left by a builder killed outright (we hold the lock)
            shutil.rmtree(stale, ignore_errors=True)
        tmp = base / f".{key}.tmp-{uuid.uuid4().hex[:8]}"
        tmp.mkdir()
        try:
            t0 = time.perf_counter()
            fields = build(tmp)
            manifest = {
                "kind": kind,
                "key": key,
                "config": config,
                "created_at": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
                "build_wall_s": round(time.perf_counter() - t0, 3),
                **(provenance() if provenance else {}),
                **fields,
            }
            (tmp / MANIFEST).write_text(json.dumps(manifest, indent=2, sort_keys=True, default=str))
            os.replace(tmp, folder)
            shutil.rmtree(base / f".{key}.partial", ignore_errors=True)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
    return folder, read_manifest(folder, key), True
