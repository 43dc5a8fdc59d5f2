"""Artifacts on disk: a folder per content key, built once under a file lock, written to
a temporary name and renamed into place, with a manifest that is checked on load.

Concurrent jobs of a sweep that need the same artifact: the first builds it, the others
wait on the lock and then load what it built.

The manifest holds the size and sha256 of every file, verified on every load (about
30 ms for a 50 MB file), so that a file damaged on disk or edited by hand is rebuilt
instead of loaded. Manifests written before the checksums (no "checksums" key) are
legacy: their files are checked once by the caller's `check` (sizes, loadability) and
their checksums recorded then; a legacy file edited while still loadable is trusted.
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
CHECKSUMS = "checksums"
_BLOCK = 1 << 20  # hashed in 1 MiB blocks: constant memory for any file size


class ArtifactError(Exception):
    """An artifact on disk is missing pieces or belongs to another config."""


def content_key(config: dict) -> str:
    """A short stable hash of the config that produces an artifact."""
    text = json.dumps(config, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


SET_META = "meta.json"  # a shipped set's description: format, content key, its files' checksums


def read_set_meta(folder: Path, fmt: str) -> dict:
    """A shipped set's meta.json, which must be of format `fmt`; ArtifactError naming it."""
    try:
        meta = json.loads((folder / SET_META).read_text())
    except (OSError, ValueError) as e:
        raise ArtifactError(f"{folder / SET_META}: unreadable ({e})") from None
    if not isinstance(meta, dict) or meta.get("format") != fmt:
        raise ArtifactError(f"{folder / SET_META}: not a {fmt} set")
    return meta


def find_set(root: Path, fmt: str, key: str) -> Path | None:
    """The set of format `fmt` under root exported from the artifact with this content key."""
    for meta_path in sorted(root.glob(f"*/{SET_META}")):
        try:
            if read_set_meta(meta_path.parent, fmt)["key"] == key:
                return meta_path.parent
        except ArtifactError:
            continue
    return None


def file_checksum(path: Path) -> dict:
    """{"bytes", "sha256"} of a file, as the manifest records it."""
    digest = hashlib.sha256()
    size = 0
    with open(path, "rb") as f:
        while block := f.read(_BLOCK):
            digest.update(block)
            size += len(block)
    return {"bytes": size, "sha256": digest.hexdigest()}


def _verify_files(folder: Path, manifest: dict) -> None:
    """Every listed file as the manifest recorded it (size first: the cheap check)."""
    sums = manifest[CHECKSUMS]
    for name in manifest.get("files", []):
        path = folder / name
        want = sums.get(name)
        if not isinstance(want, dict):
            raise ArtifactError(f"{path}: no checksum in {folder / MANIFEST}")
        try:
            size = path.stat().st_size
            if size != want.get("bytes"):
                raise ArtifactError(f"{path}: {size} bytes, the manifest says {want.get('bytes')}")
            if file_checksum(path)["sha256"] != want.get("sha256"):
                raise ArtifactError(f"{path}: sha256 differs from the manifest's (the file changed since it was built)")
        except OSError as e:
            raise ArtifactError(f"{path}: unreadable ({e.strerror or e})") from None


def read_manifest(folder: Path, key: str, verify: bool = True) -> dict:
    """The artifact's manifest, its key and files checked (and, with verify, the files'
    sizes and checksums where the manifest has them); ArtifactError otherwise."""
    path = folder / MANIFEST
    try:
        manifest = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise ArtifactError(f"{path}: unreadable manifest ({e})") from None
    if not isinstance(manifest, dict) or manifest.get("key") != key:
        got = manifest.get("key") if isinstance(manifest, dict) else None
        raise ArtifactError(f"{path}: built for key {got!r}, expected {key!r}")
    missing = [f for f in manifest.get("files", []) if not (folder / f).exists()]
    if missing:
        raise ArtifactError(f"{folder}: missing {', '.join(missing)}")
    if verify and manifest.get(CHECKSUMS) is not None:
        if not isinstance(manifest[CHECKSUMS], dict):
            raise ArtifactError(f"{path}: checksums must be an object")
        _verify_files(folder, manifest)
    return manifest


def _write_manifest(folder: Path, manifest: dict) -> None:
    tmp = folder / f".{MANIFEST}.{uuid.uuid4().hex[:8]}"
    tmp.write_text(json.dumps(manifest, indent=2, sort_keys=True, default=str))
    os.replace(tmp, folder / MANIFEST)


def _adopt_legacy(folder: Path, manifest: dict, check: Callable[[Path, dict], None] | None, record: bool) -> dict:
    """A manifest from before the checksums: the caller's check (ArtifactError when the
    files do not load), then the checksums recorded so that later loads verify them."""
    if check is not None:
        check(folder, manifest)
    if not record:
        return manifest
    try:
        sums = {name: file_checksum(folder / name) for name in manifest.get("files", [])}
        manifest = {**manifest, CHECKSUMS: sums, "checksums_recorded_at": _now()}
        _write_manifest(folder, manifest)
    except OSError:
        pass  # a read-only cache: verified now, recorded by a later writer
    return manifest


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


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
    check: Callable[[Path, dict], None] | None = None,
    notify: Callable[[str], None] | None = None,
) -> tuple[Path, dict, bool]:
    """The artifact of `kind` for `config` under `root`, building it if absent or damaged.

    build(tmp_folder) writes the files and returns manifest fields (must include "files");
    provenance() gives further manifest fields, asked for only when building.
    check(folder, manifest) raises ArtifactError when a legacy artifact's files do not
    load; notify(message) hears why a damaged artifact is rebuilt (mpnet does not print).
    An artifact that cannot be rebuilt here (a read-only cache) raises ArtifactError.
    Returns (folder, manifest, built_now)."""
    key = content_key({"kind": kind, **config})
    base = Path(root) / kind
    folder = base / key
    damage = None
    if folder.exists():
        try:
            manifest = read_manifest(folder, key)
            if manifest.get(CHECKSUMS) is not None:
                return folder, manifest, False
        except ArtifactError as e:
            damage = str(e)  # rebuilt below, under the lock
    try:
        base.mkdir(parents=True, exist_ok=True)
        lock = FileLock(str(base / f"{key}.lock"))
        lock.acquire()
    except OSError as e:
        if damage is None and folder.exists():  # a legacy artifact in a read-only cache
            return folder, _adopt_legacy(folder, read_manifest(folder, key), check, record=False), False
        what = damage or f"{folder}: not built"
        raise ArtifactError(f"{what}; cannot build it under {base} ({e.strerror or e})") from None
    try:
        return _ensure_locked(base, folder, kind, key, config, build, provenance, check, notify)
    finally:
        lock.release()


def _ensure_locked(base, folder, kind, key, config, build, provenance, check, notify) -> tuple[Path, dict, bool]:
    damage = None
    if folder.exists():
        try:
            manifest = read_manifest(folder, key)
            if manifest.get(CHECKSUMS) is None:
                manifest = _adopt_legacy(folder, manifest, check, record=True)
            return folder, manifest, False
        except ArtifactError as e:
            damage = str(e)
        if notify is not None:
            notify(f"{damage}; rebuilding {folder}")
        try:
            shutil.rmtree(folder)
        except OSError as e:
            raise ArtifactError(f"{damage}; cannot remove {folder} to rebuild it ({e.strerror or e})") from None
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
            "created_at": _now(),
            "build_wall_s": round(time.perf_counter() - t0, 3),
            **(provenance() if provenance else {}),
            **fields,
            CHECKSUMS: {name: file_checksum(tmp / name) for name in fields["files"]},
            **({"rebuilt_after": damage} if damage else {}),
        }
        (tmp / MANIFEST).write_text(json.dumps(manifest, indent=2, sort_keys=True, default=str))
        os.replace(tmp, folder)
        shutil.rmtree(base / f".{key}.partial", ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return folder, read_manifest(folder, key), True
