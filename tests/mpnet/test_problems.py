"""Problem files (docs/environments.md): loading, validation errors, dump/load round trip."""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mpnet.envs.robots import PointRobot
from mpnet.envs.spaces import EuclideanSpace
from mpnet.envs.spec import EnvSpec
from mpnet.envs.spec import TestSet as TSet  # not "Test*": pytest would try to collect it
from mpnet.envs.specs import SPECS, generated
from mpnet.envs.workspace import Query, Workspace
from mpnet.problems import FORMAT, FORMAT_2, ProblemFileError, dump_problems, load_problems
from tests.conftest import REPO_ROOT

DATA = REPO_ROOT / "tests" / "data" / "problems"

# file -> (env chosen on the command line, substrings the one-line message must hold)
WS = "workspace 'narrow-gap' (#1)"
BAD = {
    "bad_not_utf8.json": ("s2d", ["not UTF-8"]),
    "bad_not_json.json": ("s2d", ["not valid JSON", "line 5 column 48"]),
    "bad_top_level.json": ("s2d", ["top level must be a JSON object", "got a list"]),
    "bad_missing_format.json": ("s2d", ["missing key 'format'", FORMAT]),
    "bad_wrong_format.json": ("s2d", ["mpnet-bench/problems@9", f"expected {FORMAT!r} or {FORMAT_2!r}"]),
    "bad_missing_env.json": ("s2d", ["missing key 'env'"]),
    "bad_unknown_env.json": ("s2d", ["unknown env 's4d'", "c2d, c3d, mbm_fetch, mbm_ur5, panda_mbm, rigid, s2d"]),
    "bad_env_mismatch.json": ("s2d", ["'c2d'", "'s2d'"]),
    "bad_missing_workspaces.json": ("s2d", ["missing key 'workspaces'"]),
    "bad_workspaces_not_list.json": ("s2d", ["workspaces must be a list", "got an object"]),
    "bad_empty_workspaces.json": ("s2d", ["workspaces is empty"]),
    "bad_workspace_not_object.json": ("s2d", ["workspace #2", "must be an object", "got a string"]),
    "bad_missing_id.json": ("s2d", ["workspace #1", "missing key 'id'"]),
    "bad_id_not_string.json": ("s2d", ["workspace #1", "id must be a string", "got a number (7)"]),
    "bad_empty_id.json": ("s2d", ["workspace #1", "non-empty string"]),
    "bad_duplicate_id.json": ("s2d", ["workspace 'open' (#1)", "duplicate workspace id 'open'", "workspace #0"]),
    "bad_missing_obstacles.json": ("s2d", [WS, "missing key 'obstacles'"]),
    "bad_obstacles_not_list.json": ("s2d", [WS, "obstacles must be a list", "got an object"]),
    "bad_obstacle_not_object.json": ("s2d", [WS, "obstacle #1", "must be an object", "got a list"]),
    "bad_missing_center.json": ("s2d", [WS, "obstacle #1", "missing key 'center'"]),
    "bad_missing_size.json": ("s2d", [WS, "obstacle #1", "missing key 'size'"]),
    "bad_center_not_list.json": ("s2d", [WS, "obstacle #1", "center must be a list of 2 numbers"]),
    "bad_center_dim.json": ("s2d", [WS, "obstacle #1", "center has 3 numbers, env s2d needs 2"]),
    "bad_size_dim.json": ("s2d", [WS, "obstacle #1", "size has 1 number, env s2d needs 2"]),
    "bad_c3d_center_dim.json": ("c3d", [WS, "obstacle #1", "center has 2 numbers, env c3d needs 3"]),
    "bad_zero_size.json": ("s2d", [WS, "obstacle #1", "size[1] is 0", "positive"]),
    "bad_negative_size.json": ("s2d", [WS, "obstacle #1", "size[0] is -5", "positive"]),
    "bad_missing_queries.json": ("s2d", [WS, "missing key 'queries'"]),
    "bad_queries_not_list.json": ("s2d", [WS, "queries must be a list", "got an object"]),
    "bad_query_not_object.json": ("s2d", [WS, "query #2", "must be an object", "got a list"]),
    "bad_missing_start.json": ("s2d", [WS, "query #2", "missing key 'start'"]),
    "bad_missing_goal.json": ("s2d", [WS, "query #2", "missing key 'goal'"]),
    "bad_state_dim.json": ("s2d", [f"{WS}, query #2: goal has 3 numbers, env s2d needs 2"]),
    "bad_rigid_state_dim.json": ("rigid", [WS, "query #2", "start has 2 numbers, env rigid needs 3"]),
    "bad_number_as_string.json": ("s2d", [WS, "query #2", "goal[0] must be a number", 'got a string ("15.0")']),
    "bad_boolean_number.json": ("s2d", [WS, "query #2", "start[0] must be a number", "got a boolean"]),
    "bad_null_number.json": ("s2d", [WS, "query #2", "start[0] must be a number", "got null"]),
    "bad_reference_cost_negative.json": ("s2d", [WS, "query #2", "reference_cost is -3", "positive"]),
    "bad_reference_cost_string.json": ("s2d", [WS, "query #2", "reference_cost must be a number"]),
    "bad_nan.json": ("s2d", [WS, "query #2", "goal[1] is NaN"]),
    "bad_infinity.json": ("s2d", [WS, "query #2", "start[0] is -Infinity"]),
    "bad_overflow.json": ("s2d", [WS, "obstacle #1", "center[1] is 1e999"]),
    "bad_nan_size.json": ("s2d", [WS, "obstacle #1", "size[0] is NaN"]),
    "bad_nan_reference_cost.json": ("s2d", [WS, "query #2", "reference_cost is NaN"]),
    "bad_nan_extra_key.json": ("s2d", [WS, "query #2", "note.weight", "NaN"]),
    "bad_nan_top_extra_key.json": ("s2d", ["scale", "Infinity"]),
    "bad_no_queries.json": ("s2d", ["no queries"]),
}

VALID = {"s2d": "s2d.json", "c2d": "c2d.json", "c3d": "c3d.json", "rigid": "rigid.json"}


def _error(path, env: str) -> ProblemFileError:
    with pytest.raises(ProblemFileError) as info:
        load_problems(path, SPECS[env])
    return info.value


def _write(tmp_path: Path, doc_or_text, name: str = "p.json") -> Path:
    p = tmp_path / name
    p.write_text(doc_or_text if isinstance(doc_or_text, str) else json.dumps(doc_or_text), encoding="utf-8")
    return p


def _minimal(env: str = "s2d") -> dict:
    spec = SPECS[env]
    return {
        "format": FORMAT,
        "env": env,
        "workspaces": [
            {
                "id": "w",
                "obstacles": [{"center": [0.0] * spec.workspace_dim, "size": [5.0] * spec.workspace_dim}],
                "queries": [{"start": [-15.0] * spec.state_dim, "goal": [15.0] * spec.state_dim}],
            }
        ],
    }


# --------------------------------------------------------------------------- bad files


def test_every_bad_file_is_in_the_table():
    on_disk = {p.name for p in DATA.glob("bad_*.json")}
    assert on_disk == set(BAD)


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_file_raises_one_line_error(name):
    env, expected = BAD[name]
    path = str(DATA / name)
    err = _error(path, env)
    msg = str(err)
    assert "\n" not in msg and "\r" not in msg
    assert msg.startswith(path + ": "), msg  # the path exactly as given
    for part in expected:
        assert part in msg, (part, msg)
    assert "Traceback" not in msg
    assert isinstance(err, ValueError)


def test_error_location_attributes():
    err = _error(DATA / "bad_state_dim.json", "s2d")
    assert (err.workspace_id, err.workspace_index, err.query_index) == ("narrow-gap", 1, 2)
    assert err.detail == "goal has 3 numbers, env s2d needs 2 (state dimension)"
    err = _error(DATA / "bad_wrong_format.json", "s2d")
    assert (err.workspace_id, err.workspace_index, err.query_index) == (None, None, None)


def test_path_given_as_relative_string_is_named_as_given(monkeypatch):
    monkeypatch.chdir(DATA)
    assert str(_error("bad_nan.json", "s2d")).startswith("bad_nan.json: workspace 'narrow-gap' (#1), query #2: ")


def test_missing_file(tmp_path):
    path = tmp_path / "nope.json"
    msg = str(_error(path, "s2d"))
    assert msg.startswith(f"{path}: ") and "no such file" in msg and "\n" not in msg


def test_directory_is_not_a_problem_file(tmp_path):
    msg = str(_error(tmp_path, "s2d"))
    assert msg.startswith(f"{tmp_path}: ") and "cannot read" in msg


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs file permissions")
def test_unreadable_file(tmp_path):
    p = _write(tmp_path, _minimal())
    p.chmod(0)
    try:
        msg = str(_error(p, "s2d"))
    finally:
        p.chmod(0o644)
    assert msg.startswith(f"{p}: cannot read the file")


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_literals_rejected(tmp_path, literal):
    text = json.dumps(_minimal()).replace('"goal": [15.0, 15.0]', f'"goal": [15.0, {literal}]')
    assert literal in text
    p = _write(tmp_path, text)
    msg = str(_error(p, "s2d"))
    assert f"is {literal}" in msg and "workspace 'w' (#0), query #0" in msg


def test_nan_literal_under_an_ignored_key_is_rejected(tmp_path):
    text = json.dumps(_minimal()).replace('"workspaces"', '"extra": {"x": [1, NaN]}, "workspaces"')
    msg = str(_error(_write(tmp_path, text), "s2d"))
    assert "extra.x[1]" in msg and "NaN" in msg


def test_newline_in_id_keeps_the_message_on_one_line(tmp_path):
    doc = _minimal()
    doc["workspaces"][0]["id"] = "two\nlines"
    doc["workspaces"][0]["queries"][0]["goal"] = [1.0]
    msg = str(_error(_write(tmp_path, doc), "s2d"))
    assert "\n" not in msg and "two\\nlines" in msg and "query #0" in msg


def test_env_mismatch_names_both(tmp_path):
    msg = str(_error(_write(tmp_path, _minimal("rigid")), "s2d"))
    assert "'rigid'" in msg and "'s2d'" in msg


def test_whitespace_only_id_rejected(tmp_path):
    doc = _minimal()
    doc["workspaces"][0]["id"] = "   "
    assert "non-empty" in str(_error(_write(tmp_path, doc), "s2d"))


def test_huge_integer_literal_is_not_finite(tmp_path):
    doc = _minimal()
    text = json.dumps(doc).replace("[-15.0, -15.0]", "[-15.0, " + "9" * 400 + "]")
    msg = str(_error(_write(tmp_path, text), "s2d"))
    assert "query #0" in msg and "start[1]" in msg and "not a finite number" in msg


# --------------------------------------------------------------------------- valid files


def _box_distance(p, centers, sizes) -> np.ndarray:
    d = np.maximum(np.abs(np.asarray(p) - centers) - sizes / 2, 0)
    return np.linalg.norm(d, axis=1)


@pytest.mark.parametrize("env", sorted(VALID))
def test_valid_file_loads(env):
    spec = SPECS[env]
    ts = load_problems(DATA / VALID[env], spec)
    assert isinstance(ts, TSet) and ts.spec is spec
    assert len(ts.workspaces) == 2 and len(ts.queries) >= 4
    ids = [w.id for w in ts.workspaces]
    assert len(set(ids)) == 2 and all(ids)
    raw = json.loads((DATA / VALID[env]).read_text())
    for w, rw in zip(ts.workspaces, raw["workspaces"]):
        assert w.id == rw["id"] and w.split == "file"
        assert w.centers.shape == w.sizes.shape == (len(rw["obstacles"]), spec.workspace_dim)
        boxes = sorted(zip(map(tuple, w.centers.tolist()), map(tuple, w.sizes.tolist())))  # the canonical order
        assert boxes == sorted((tuple(o["center"]), tuple(o["size"])) for o in rw["obstacles"])
        assert np.all(w.sizes > 0)
        qs = [q for q in ts.queries if q.workspace_id == w.id]
        assert [q.id for q in qs] == [f"{w.id}/{i}" for i in range(len(rw["queries"]))]
        for q, rq in zip(qs, rw["queries"]):
            assert q.split == "file"
            assert q.start.shape == q.goal.shape == (spec.state_dim,)
            assert q.start.tolist() == rq["start"] and q.goal.tolist() == rq["goal"]
            assert q.reference_cost == rq.get("reference_cost")
        assert ts.workspace(w.id, "file") is w
    assert len({q.id for q in ts.queries}) == len(ts.queries)


@pytest.mark.parametrize("env", sorted(VALID))
def test_valid_files_are_good_benchmarks(env):
    """Starts and goals are clearly free and in bounds; the straight line hits a box."""
    spec = SPECS[env]
    margin = 3.0 if spec.robot.kind == "rectangle" else 0.5  # 3 > half-diagonal of the 2x5 robot
    ts = load_problems(DATA / VALID[env], spec)
    n = spec.workspace_dim
    for q in ts.queries:
        w = ts.workspace(q.workspace_id, q.split)
        for p in (q.start, q.goal):
            assert np.all(np.abs(p[:n]) <= 20)
            assert _box_distance(p[:n], w.centers, w.sizes).min() >= margin, q.id
        ts_ = np.linspace(0, 1, 1001)[:, None]
        line = q.start[:n] + ts_ * (q.goal[:n] - q.start[:n])
        assert any(np.all((line >= lo) & (line <= hi), axis=1).any() for lo, hi in zip(w.lo, w.hi)), q.id


def test_valid_files_have_a_reference_cost_somewhere():
    ts = load_problems(DATA / "s2d.json", SPECS["s2d"])
    assert ts.queries[0].reference_cost == 31.5
    assert all(q.reference_cost is None for q in ts.queries[1:])


def test_invalid_queries_are_not_format_errors(tmp_path):
    """Collisions and out-of-bounds states are the planner's `invalid_query`, not ours."""
    doc = _minimal()
    doc["workspaces"][0]["queries"] = [{"start": [0.0, 0.0], "goal": [50.0, -300.0]}]
    ts = load_problems(_write(tmp_path, doc), SPECS["s2d"])
    assert ts.queries[0].goal.tolist() == [50.0, -300.0]


def test_rigid_theta_may_be_any_finite_number(tmp_path):
    doc = _minimal("rigid")
    doc["workspaces"][0]["queries"][0] = {"start": [-15.0, -15.0, 7.5], "goal": [15.0, 15.0, -100]}
    q = load_problems(_write(tmp_path, doc), SPECS["rigid"]).queries[0]
    assert q.start[2] == 7.5 and q.goal[2] == -100.0


def test_unknown_keys_are_ignored_and_ints_accepted(tmp_path):
    doc = _minimal()
    doc["comment"] = "made by hand"
    doc["workspaces"][0]["tags"] = ["x"]
    doc["workspaces"][0]["obstacles"][0]["color"] = "red"
    doc["workspaces"][0]["queries"][0].update(note={"a": 1}, start=[-15, 3], reference_cost=None)
    ts = load_problems(_write(tmp_path, doc), SPECS["s2d"])
    assert ts.queries[0].start.tolist() == [-15.0, 3.0] and ts.queries[0].reference_cost is None


def test_workspace_without_queries_is_fine_when_others_have_some(tmp_path):
    doc = _minimal()
    doc["workspaces"].insert(0, {"id": "empty", "obstacles": doc["workspaces"][0]["obstacles"], "queries": []})
    ts = load_problems(_write(tmp_path, doc), SPECS["s2d"])
    assert [w.id for w in ts.workspaces] == ["empty", "w"] and [q.id for q in ts.queries] == ["w/0"]


def test_custom_spec_not_in_specs_loads_when_names_match(tmp_path):
    spec = EnvSpec("arm7", EuclideanSpace(((-3.0, 3.0),) * 7), PointRobot(), 3, generator=None)
    doc = {
        "format": FORMAT,
        "env": "arm7",
        "workspaces": [
            {
                "id": "table",
                "obstacles": [{"center": [0.5, 0, 0.2], "size": [1, 1, 0.4]}],
                "queries": [{"start": [0.0] * 7, "goal": [0.5] * 7}],
            }
        ],
    }
    ts = load_problems(_write(tmp_path, doc), spec)
    assert ts.queries[0].goal.shape == (7,)


# --------------------------------------------------------------------------- dump / load


def _assert_same(a: TSet, b: TSet):
    assert a.spec == b.spec
    assert [(w.id, w.split) for w in a.workspaces] == [(w.id, w.split) for w in b.workspaces]
    for wa, wb in zip(a.workspaces, b.workspaces):
        assert np.array_equal(wa.centers, wb.centers) and np.array_equal(wa.sizes, wb.sizes)
    assert len(a.queries) == len(b.queries)
    for qa, qb in zip(a.queries, b.queries):
        assert (qa.id, qa.workspace_id, qa.split, qa.reference_cost) == (
            qb.id,
            qb.workspace_id,
            qb.split,
            qb.reference_cost,
        )
        assert np.array_equal(qa.start, qb.start) and np.array_equal(qa.goal, qb.goal)


@pytest.mark.parametrize("env", sorted(VALID))
def test_fixture_round_trip(env, tmp_path):
    ts = load_problems(DATA / VALID[env], SPECS[env])
    out = tmp_path / "out.json"
    dump_problems(out, ts)
    again = load_problems(out, SPECS[env])
    _assert_same(ts, again)
    doc = json.loads(out.read_text())
    assert doc["format"] == FORMAT and doc["env"] == env
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]  # no temp file left behind


def test_dump_generated_test_set_with_splits(tmp_path):
    spec = SPECS["s2d"]
    box = dict(centers=[[0.0, 0.0]], sizes=[[5.0, 5.0]])
    ts = TSet(
        spec,
        [Workspace("0", "seen", **box), Workspace("100", "unseen", **box)],
        [
            Query("0/0", "0", "seen", [-15, 0], [15, 0]),
            Query("100/0", "100", "unseen", [0, -15], [0, 15], reference_cost=30.0),
            Query("0/1", "0", "seen", [-15, 1], [15, 1]),
        ],
    )
    out = tmp_path / "gen.json"
    dump_problems(out, ts)
    back = load_problems(out, spec)
    assert [w.split for w in back.workspaces] == ["file", "file"]
    assert [q.id for q in back.queries] == ["0/0", "0/1", "100/0"]  # grouped under their workspace
    assert back.queries[2].reference_cost == 30.0
    dump_problems(out, ts, split="unseen")
    assert [q.id for q in load_problems(out, spec).queries] == ["100/0"]


def test_dump_rejects_ambiguous_ids_across_splits(tmp_path):
    spec = SPECS["s2d"]
    box = dict(centers=[[0.0, 0.0]], sizes=[[5.0, 5.0]])
    ts = TSet(
        spec,
        [Workspace("0", "seen", **box), Workspace("0", "unseen", **box)],
        [Query("0/0", "0", "seen", [1, 1], [2, 2])],
    )
    with pytest.raises(ValueError, match="split="):
        dump_problems(tmp_path / "x.json", ts)
    dump_problems(tmp_path / "x.json", ts, split="seen")
    assert len(load_problems(tmp_path / "x.json", spec).queries) == 1


def test_dump_refuses_what_load_would_reject(tmp_path):
    spec = SPECS["s2d"]
    ts = TSet(
        spec,
        [Workspace("w", "file", [[0.0, 0.0]], [[5.0, 5.0]])],
        [Query("w/0", "w", "file", [1.0, math.nan], [2.0, 2.0])],
    )
    out = tmp_path / "x.json"
    with pytest.raises(ProblemFileError, match=r"workspace 'w' \(#0\), query #0: start\[1\]"):
        dump_problems(out, ts)
    assert not any(tmp_path.iterdir())


# hypothesis: random valid test sets survive dump -> load unchanged
_num = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
_pos = st.floats(min_value=1e-6, max_value=1e6, allow_nan=False, allow_infinity=False)
_ids = st.text(min_size=1, max_size=12).filter(lambda s: s.strip())


@st.composite
def _testsets(draw):
    spec = SPECS[draw(st.sampled_from(sorted(generated())))]
    wdim, sdim = spec.workspace_dim, spec.state_dim
    ids = draw(st.lists(_ids, min_size=1, max_size=4, unique=True))
    workspaces, queries = [], []
    for wid in ids:
        n = draw(st.integers(1, 4))
        centers = draw(st.lists(st.lists(_num, min_size=wdim, max_size=wdim), min_size=n, max_size=n))
        sizes = draw(st.lists(st.lists(_pos, min_size=wdim, max_size=wdim), min_size=n, max_size=n))
        workspaces.append(Workspace(wid, "file", centers, sizes))
        for i in range(draw(st.integers(0, 3))):
            start = draw(st.lists(_num, min_size=sdim, max_size=sdim))
            goal = draw(st.lists(_num, min_size=sdim, max_size=sdim))
            ref = draw(st.none() | _pos)
            queries.append(Query(f"{wid}/{i}", wid, "file", start, goal, reference_cost=ref))
    if not queries:
        w = workspaces[0]
        queries.append(Query(f"{w.id}/0", w.id, "file", [0.0] * sdim, [1.0] * sdim))
    # the loader lists queries grouped by workspace, in file order
    order = {w.id: k for k, w in enumerate(workspaces)}
    queries.sort(key=lambda q: (order[q.workspace_id], int(q.id.rsplit("/", 1)[1])))
    return TSet(spec, workspaces, queries)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_testsets())
@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_round_trip_property(ts):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "p.json"
        dump_problems(path, ts)
        back = load_problems(path, ts.spec)
        _assert_same(ts, back)
        dump_problems(Path(d) / "q.json", back)
        assert (Path(d) / "q.json").read_text() == path.read_text()


def test_workspace_without_obstacles_loads():
    ts = load_problems(DATA / "s2d_empty_workspace.json", SPECS["s2d"])
    empty = ts.workspace("narrow-gap", "file")
    assert empty.centers.shape == (0, 2) and empty.sizes.shape == (0, 2)
    assert len([q for q in ts.queries if q.workspace_id == "narrow-gap"]) == 3
