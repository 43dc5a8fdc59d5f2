"""The sphere model kept on disk (mpnet.envs.checkers.sphere_store): a stored model is the
built one, and a store that does not match the model's files (edited, damaged) is never used."""

from __future__ import annotations

import json
import shutil
import uuid

import numpy as np
import pytest

from mpnet.envs.arm.model import load_arm_model, robot_file
from mpnet.envs.checkers.sphere_store import FOLDER, stored
from mpnet.envs.checkers.spheres import SphereModel


def _copy_of_panda(folder, tag: str) -> str:
    """The packaged Panda in `folder` as another robot file (its own sphere file; its `name`
    not the file's): a model whose files a test may edit."""
    name = f"panda_store_{tag}_{uuid.uuid4().hex[:6]}"
    text = robot_file("panda.yaml").read_text()
    text = text.replace("name: panda\n", f"name: {name}_named\n")
    text = text.replace("spheres: panda_spheres.json", f"spheres: {name}.json")
    (folder / f"{name}.yaml").write_text(text)
    shutil.copy(robot_file("panda_spheres.json"), folder / f"{name}.json")
    return name


def _equal(a: SphereModel, b: SphereModel) -> bool:
    if set(vars(a)) != set(vars(b)):
        return False
    for k, v in vars(a).items():
        w = getattr(b, k)
        if isinstance(v, np.ndarray):
            if v.dtype != w.dtype or not np.array_equal(v, w):
                return False
        elif v != w:
            return False
    return True


@pytest.mark.slow
def test_a_stored_model_is_the_built_one_and_a_changed_or_damaged_store_is_built_again(tmp_path, monkeypatch):
    robots, kernels = tmp_path / "robots", tmp_path / "kernels"
    robots.mkdir()
    monkeypatch.setenv("MPNET_BENCH_ROBOTS", str(robots))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(kernels))
    name = _copy_of_panda(robots, "a")
    builds = []

    def build(model):
        builds.append(model.name)
        return SphereModel(model)

    model, description = load_arm_model(name), robots / f"{name}.yaml"

    def store(model):
        return stored(model, build, description)

    first = store(model)
    (path,) = (kernels / FOLDER).iterdir()
    again = store(model)
    named = f"{name}_named"
    assert builds == [named] and again is not first and _equal(first, again) and again.model is model

    blob = bytearray(path.read_bytes())  # a flipped bit in the arrays: built again, the store replaced
    blob[-100] ^= 1
    path.write_bytes(bytes(blob))
    assert _equal(store(model), first) and builds == [named, named]
    path.write_bytes(path.read_bytes()[:-10])  # cut short
    assert _equal(store(model), first) and len(builds) == 3
    assert store(model) is not None and len(builds) == 3  # the replaced store is good

    # its description edited (a narrower first joint), read again under the same name: built again
    description.write_text(description.read_text().replace("  - [-2.8973, 2.8973]\n", "  - [-2.5, 2.5]\n", 1))
    load_arm_model.cache_clear()
    narrower = store(load_arm_model(name))
    assert builds == [named] * 4 and narrower.lower[0] == -2.5 and first.lower[0] == -2.8973
    load_arm_model.cache_clear()

    # the same robot with one sphere 0.1 mm larger: another key, its own model
    edited = _copy_of_panda(robots, "b")
    doc = json.loads((robots / f"{edited}.json").read_text())
    link = next(iter(doc["links"]))
    doc["links"][link][0][3] += 1e-4
    (robots / f"{edited}.json").write_text(json.dumps(doc))
    other = stored(load_arm_model(edited), build, robots / f"{edited}.yaml")
    assert builds[-1] == f"{edited}_named" and len(builds) == 5
    assert other.radius.max() >= first.radius.max() and not np.array_equal(other.radius, first.radius)


def test_without_a_kernel_place_nothing_is_stored(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.chdir(tmp_path)
    model = load_arm_model("panda")
    calls = []
    for _ in range(2):
        assert stored(model, lambda m: calls.append(m) or "built", robot_file("panda.yaml")) == "built"
    assert len(calls) == 2 and not any(tmp_path.iterdir())
