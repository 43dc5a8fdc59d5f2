"""The sphere model kept on disk (mpnet.envs.checkers.sphere_store): a stored model is the
built one, and a store that does not match what the build would read (an edited robot file,
URDF or sphere set; a damaged file; code changed under a running process) is never used."""

from __future__ import annotations

import json
import shutil
import uuid

import numpy as np
import pybullet_data
import pytest

from mpnet.envs.arm.model import ArmModelError, load_arm_model, robot_file
from mpnet.envs.checkers import sphere_store
from mpnet.envs.checkers.sphere_store import FOLDER, stored
from mpnet.envs.checkers.spheres import SphereModel


def _copy_of_panda(folder, tag: str) -> str:
    """The packaged Panda in `folder` as another robot file (its own sphere file and URDF; its
    `name` not the file's): a model whose files a test may edit."""
    name = f"panda_store_{tag}_{uuid.uuid4().hex[:6]}"
    (folder / name).mkdir()
    shutil.copy(f"{pybullet_data.getDataPath()}/franka_panda/panda.urdf", folder / name / "panda.urdf")
    text = robot_file("panda.yaml").read_text()
    text = text.replace("name: panda\n", f"name: {name}_named\n")
    text = text.replace("spheres: panda_spheres.json", f"spheres: {name}.json")
    text = text.replace("urdf: franka_panda/panda.urdf", f"urdf: {name}/panda.urdf")
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


@pytest.fixture
def robots(tmp_path, monkeypatch):
    folder = tmp_path / "robots"
    folder.mkdir()
    monkeypatch.setenv("MPNET_BENCH_ROBOTS", str(folder))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "kernels"))
    yield folder
    load_arm_model.cache_clear()


@pytest.mark.slow
def test_a_stored_model_is_the_built_one_and_what_changes_it_is_built_again(robots, tmp_path):
    name = _copy_of_panda(robots, "a")
    builds = []

    def build(model, doc):
        builds.append(model.name)
        return SphereModel(model, doc)

    model = load_arm_model(name)
    first = stored(model, build)
    (path,) = (tmp_path / "kernels" / FOLDER).iterdir()
    again = stored(model, build)
    assert len(builds) == 1 and again is not first and _equal(first, again) and again.model is model
    assert _equal(first, SphereModel(model))  # as built from the file

    blob = bytearray(path.read_bytes())  # a flipped bit in the arrays: built again, the store replaced
    blob[-100] ^= 1
    path.write_bytes(bytes(blob))
    assert _equal(stored(model, build), first) and len(builds) == 2
    path.write_bytes(path.read_bytes()[:-10])  # cut short
    assert _equal(stored(model, build), first) and len(builds) == 3
    assert _equal(stored(model, build), first) and len(builds) == 3  # the replaced store is good

    def edited(file, old, new):  # the robot read again under its name after an edit of one file
        file.write_text(file.read_text().replace(old, new, 1))
        load_arm_model.cache_clear()
        n = len(builds)
        out = stored(load_arm_model(name), build)
        assert len(builds) == n + 1
        return out

    narrower = edited(robots / f"{name}.yaml", "  - [-2.8973, 2.8973]\n", "  - [-2.5, 2.5]\n")
    assert narrower.lower[0] == -2.5 and first.lower[0] == -2.8973
    taller = edited(robots / name / "panda.urdf", 'xyz="0 0 0.333"', 'xyz="0 0 0.334"')
    assert not np.array_equal(taller.origin, first.origin)
    doc = json.loads((robots / f"{name}.json").read_text())
    doc["links"][next(iter(doc["links"]))][0][3] += 1e-4  # one sphere 0.1 mm larger
    larger = edited(robots / f"{name}.json", (robots / f"{name}.json").read_text(), json.dumps(doc))
    assert larger.radius.max() >= first.radius.max() and not np.array_equal(larger.radius, first.radius)


def test_a_robot_without_its_sphere_set_says_so(robots):
    name = _copy_of_panda(robots, "b")
    (robots / f"{name}.json").unlink()
    with pytest.raises(ArmModelError, match="no sphere set"):
        stored(load_arm_model(name), SphereModel)


def test_nothing_is_stored_without_a_kernel_place_or_under_changed_code(robots, tmp_path, monkeypatch):
    model = load_arm_model("panda")
    calls = []

    def build(m, doc):
        calls.append(doc)
        return "built"

    monkeypatch.setattr(sphere_store, "_IMPORTED", 0.0)  # every module "changed" since it was imported
    assert [stored(model, build) for _ in range(2)] == ["built", "built"]
    monkeypatch.setattr(sphere_store, "_IMPORTED", float("inf"))
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    assert [stored(model, build) for _ in range(2)] == ["built", "built"]
    assert calls == [None] * 4 and not (tmp_path / "kernels").exists()
