"""A dataset's training scenes kept in the cache (harness.artifacts.ensure.training_scenes): the
workspaces drawing them gives, in the data's order, read back without drawing them again."""

from types import SimpleNamespace

import numpy as np
import pytest

from harness.artifacts import ensure
from mpnet.envs.scenes.generators import make_workspaces
from mpnet.envs.specs import get_spec


@pytest.mark.slow  # three Panda scenes drawn (their IK screen): seconds
def test_training_scenes_are_drawn_once_and_read_back_equal(tmp_path, monkeypatch):
    spec = get_spec("panda_mbm")
    ids = [5, 0, 12]  # the data's order, not sorted
    data = SimpleNamespace(train_ids=np.array(ids), manifest={"key": "k" * 16, "config": {"data_seed": 0}})
    drawn = make_workspaces(spec, ids, "train", 0)
    first = ensure.training_scenes(tmp_path, spec, data)
    monkeypatch.setattr(ensure, "make_workspaces", lambda *a: pytest.fail("the scenes were drawn again"))
    again = ensure.training_scenes(tmp_path, spec, data)
    for got in (first, again):
        assert [w.id for w in got] == [w.id for w in drawn] == [str(i) for i in ids]
        assert [w.obstacles_json() for w in got] == [w.obstacles_json() for w in drawn]
        for mine, theirs in zip(
            spec.robot.clearance_arrays(got)["obstacles"], spec.robot.clearance_arrays(drawn)["obstacles"]
        ):
            assert mine.keys() == theirs.keys() and all(np.array_equal(mine[k], theirs[k]) for k in mine)
    other = SimpleNamespace(train_ids=np.array(ids[:2]), manifest=data.manifest)  # other ids: another artifact
    monkeypatch.setattr(ensure, "make_workspaces", make_workspaces)
    assert len(ensure.training_scenes(tmp_path, spec, other)) == 2
    assert len(list((tmp_path / "scenes").glob("*/scenes.json"))) == 2
