"""Artifacts are verified on load: every file's size and sha256 are in the manifest; a file
damaged on disk or edited by hand is rebuilt (or refused with one line), never loaded."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import torch

from mpnet.data.store import CHECKSUMS, MANIFEST, ArtifactError, ensure, read_manifest


def _build(calls: list):
    """A toy build: a 64 KB binary file (a stand-in for a checkpoint) and a JSON file."""

    def build(folder):
        calls.append(folder)
        (folder / "blob.bin").write_bytes(np.random.default_rng(0).bytes(64 * 1024))
        (folder / "set.json").write_text(json.dumps({"queries": [[0.0, 1.0], [2.0, 3.0]]}))
        return {"files": ["blob.bin", "set.json"]}

    return build


def _garble(path):
    """4 KB overwritten in the middle of the file, its size unchanged."""
    data = bytearray(path.read_bytes())
    mid = len(data) // 2
    data[mid : mid + 4096] = bytes(4096)
    path.write_bytes(bytes(data))


def _truncate(path):
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _hand_edit(path):
    doc = json.loads(path.read_text())
    doc["queries"][0][0] = 0.5  # still valid JSON, same shape
    path.write_text(json.dumps(doc))


def test_manifest_records_size_and_sha256_of_every_file(tmp_path):
    folder, manifest, built = ensure(tmp_path, "thing", {"a": 1}, _build([]))
    assert built and set(manifest[CHECKSUMS]) == {"blob.bin", "set.json"}
    blob = manifest[CHECKSUMS]["blob.bin"]
    assert blob["bytes"] == 64 * 1024 and len(blob["sha256"]) == 64


@pytest.mark.parametrize("damage", [_garble, _truncate, _hand_edit], ids=["garbled", "truncated", "hand-edited"])
def test_damaged_file_is_detected_and_rebuilt(tmp_path, damage):
    calls, heard = [], []
    folder, first, _ = ensure(tmp_path, "thing", {"a": 1}, _build(calls))
    name = "set.json" if damage is _hand_edit else "blob.bin"
    damage(folder / name)
    with pytest.raises(ArtifactError, match=name):
        read_manifest(folder, first["key"])
    _, manifest, built = ensure(tmp_path, "thing", {"a": 1}, _build(calls), notify=heard.append)
    assert built and len(calls) == 2
    assert len(heard) == 1 and name in heard[0] and "rebuilding" in heard[0] and "\n" not in heard[0]
    assert name in manifest["rebuilt_after"]
    assert manifest[CHECKSUMS] == first[CHECKSUMS]  # the same content, rebuilt
    assert not ensure(tmp_path, "thing", {"a": 1}, _build(calls))[2]  # and loaded from then on


def test_legacy_manifest_is_checked_once_then_verified(tmp_path):
    """A manifest from before the checksums: the caller's check runs once, the checksums
    are recorded, and later loads verify them (a later edit is caught)."""
    calls, checked = [], []
    folder, manifest, _ = ensure(tmp_path, "thing", {"a": 1}, _build(calls))
    legacy = {k: v for k, v in manifest.items() if k != CHECKSUMS}
    (folder / MANIFEST).write_text(json.dumps(legacy))
    check = lambda f, m: checked.append(f)
    for _ in range(2):
        _, got, built = ensure(tmp_path, "thing", {"a": 1}, _build(calls), check=check)
        assert not built and got[CHECKSUMS] == manifest[CHECKSUMS]
    assert checked == [folder] and len(calls) == 1
    _hand_edit(folder / "set.json")
    assert ensure(tmp_path, "thing", {"a": 1}, _build(calls), check=check)[2]


def test_legacy_artifact_that_does_not_load_is_rebuilt(tmp_path):
    calls, heard = [], []
    folder, manifest, _ = ensure(tmp_path, "thing", {"a": 1}, _build(calls))
    (folder / MANIFEST).write_text(json.dumps({k: v for k, v in manifest.items() if k != CHECKSUMS}))
    _truncate(folder / "blob.bin")

    def check(f, m):
        if (f / "blob.bin").stat().st_size != 64 * 1024:
            raise ArtifactError(f"{f / 'blob.bin'}: cut short")

    _, got, built = ensure(tmp_path, "thing", {"a": 1}, _build(calls), check=check, notify=heard.append)
    assert built and CHECKSUMS in got and "cut short" in heard[0]


def test_artifact_that_cannot_be_built_here_is_one_line(tmp_path):
    """A cache under a regular file: ArtifactError naming the folder, not an OSError."""
    (tmp_path / "file").write_text("x")
    with pytest.raises(ArtifactError) as info:
        ensure(tmp_path / "file" / "cache", "thing", {"a": 1}, _build([]))
    assert "file/cache/thing" in str(info.value) and "\n" not in str(info.value)


def test_truncated_data_npz_is_one_line_naming_it(tmp_path):
    from mpnet.data.dataset import DATA_FILE, load_dataset

    np.savez_compressed(tmp_path / DATA_FILE, path_states=np.zeros((100, 2)))
    _truncate(tmp_path / DATA_FILE)
    with pytest.raises(ArtifactError) as info:
        load_dataset(tmp_path, {})
    assert str(info.value).startswith(f"{tmp_path / DATA_FILE}: unreadable") and "\n" not in str(info.value)


@pytest.mark.parametrize("damage", [_truncate, lambda p: p.write_bytes(b""), lambda p: p.write_text("hello")])
def test_unreadable_checkpoint_is_one_line_naming_it(tmp_path, damage):
    from mpnet.models import CheckpointError, load_pnet_checkpoint

    path = tmp_path / "pnet.ckpt"
    torch.save({"hyper_parameters": {}, "state_dict": {"w": torch.zeros(5000)}}, path)
    damage(path)
    with pytest.raises(CheckpointError) as info:
        load_pnet_checkpoint(path)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)


def test_hand_edited_cached_test_set_is_rebuilt(tmp_path, settings, capsys):
    """The probe's case: a cached test set edited by hand (still a valid problem file) was
    used as is; now it is rebuilt, with a warning naming the file."""
    from harness.artifacts.ensure import ensure_testset

    run = settings(["+env=s2d", "scale=tiny", f"cache_dir={tmp_path}"])
    want = ensure_testset(run, progress=False)
    (folder,) = (tmp_path / "testset").glob("*/")
    doc = json.loads((folder / "seen.json").read_text())
    doc["workspaces"][0]["queries"][0]["start"][0] += 0.5
    (folder / "seen.json").write_text(json.dumps(doc))
    got = ensure_testset(run, progress=False)
    assert f"warning: {folder / 'seen.json'}" in capsys.readouterr().err
    assert all(np.array_equal(a.start, b.start) for a, b in zip(got.queries, want.queries))


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs file permissions")
def test_damaged_artifact_in_a_read_only_cache_is_refused(tmp_path):
    folder, _, _ = ensure(tmp_path, "thing", {"a": 1}, _build([]))
    _garble(folder / "blob.bin")
    (tmp_path / "thing" / f"{folder.name}.lock").unlink()
    (tmp_path / "thing").chmod(0o555)
    try:
        with pytest.raises(ArtifactError, match="blob.bin.*cannot"):
            ensure(tmp_path, "thing", {"a": 1}, _build([]))
    finally:
        (tmp_path / "thing").chmod(0o755)


@pytest.mark.slow  # trains a tiny s2d model set in subprocesses
def test_damaged_checkpoint_and_dataset_are_rebuilt_end_to_end(tmp_path, run_cli):
    """The probe's cases through the CLI: 4 KB garbled in pnet.ckpt (it loaded without error
    and planned at 0%) and a truncated data.npz (a traceback on every later run)."""
    args = ("harness.train", "+env=s2d", "scale=tiny", "progress=false", f"cache_dir={tmp_path}")
    first = run_cli(*args, f"hydra.run.dir={tmp_path / 'r1'}")
    assert "trained:" in first.stdout
    (models,) = (tmp_path / "models").glob("*/")
    (data,) = (tmp_path / "data").glob("*/")
    _garble(models / "pnet.ckpt")
    again = run_cli(*args, f"hydra.run.dir={tmp_path / 'r2'}")
    assert "trained:" in again.stdout and f"warning: {models / 'pnet.ckpt'}" in again.stderr
    assert "pnet.ckpt" in read_manifest(models, models.name)["rebuilt_after"]  # and it verifies
    _truncate(data / "data.npz")
    third = run_cli(*args, f"hydra.run.dir={tmp_path / 'r3'}")
    assert "cached:" in third.stdout  # cached models need the dataset's key, not its files
    fourth = run_cli("harness.data", *args[1:], f"hydra.run.dir={tmp_path / 'r4'}")  # the dataset itself
    assert f"warning: {data / 'data.npz'}" in fourth.stderr
    assert "Traceback" not in first.stderr + again.stderr + third.stderr + fourth.stderr
