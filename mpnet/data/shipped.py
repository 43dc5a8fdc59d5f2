"""Test sets that ship with the package, so that a fresh clone plans at once: building a
quick test set takes minutes (its queries' solvability checks and reference costs), far
longer than planning it.

A set is a folder of problem files plus meta.json (format, the test set artifact's
content key and key config, each file's size and sha256, the manifest's reference
fields). It stands in for exactly the artifact of that key: the cache gets a copy,
verified, and builds nothing.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from mpnet.data.store import SET_META as META
from mpnet.data.store import ArtifactError, file_checksum, find_set, read_set_meta

FORMAT = "mpnet-bench/shipped-testset@1"
SHIPPED = Path(__file__).resolve().parents[1] / "data_files" / "testsets"


def export_testset(folder: Path, manifest: dict, out: Path) -> dict:
    """Write a cached test set artifact (folder, manifest) into folder `out`; its meta."""
    out.mkdir(parents=True, exist_ok=True)
    for name in manifest["files"]:
        shutil.copyfile(folder / name, out / name)
    meta = {
        "format": FORMAT,
        "key": manifest["key"],
        "config": manifest["config"],
        "files": {name: file_checksum(out / name) for name in manifest["files"]},
        "manifest": {k: manifest[k] for k in ("format", "queries", "reference") if k in manifest},
    }
    (out / META).write_text(json.dumps(meta, indent=2, sort_keys=True) + "\n")
    return meta


def read_meta(folder: Path) -> dict:
    return read_set_meta(folder, FORMAT)


def find_testset(key: str, root: Path = SHIPPED) -> Path | None:
    """The shipped set exported from the test set artifact with this content key."""
    return find_set(root, FORMAT, key)


def copy_testset(source: Path, folder: Path) -> dict:
    """The shipped set's files into `folder`, each verified against meta.json; returns
    the manifest fields the artifact records."""
    meta = read_meta(source)
    for name, expected in meta["files"].items():
        got = file_checksum(source / name)
        if got != expected:
            raise ArtifactError(f"{source / name}: {got} differs from {source / META}'s {expected}")
        shutil.copyfile(source / name, folder / name)
    return {**meta["manifest"], "files": list(meta["files"]), "source": str(source)}
