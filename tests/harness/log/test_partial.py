"""Recordings that show failure: a failed query's Result carries what the planner had
(Result.partial), /query logs it as `partial`, and Rerun and Foxglove draw it in the
colours their legends explain."""

from __future__ import annotations

import json
import time

import jsonschema
import numpy as np
import pytest
from ompl import util as ou

from harness.bench.loop import PARTIAL_MAX_STATES, logged_partial, plan_query, warm_up
from harness.log import TrialLog, painter_for, scene_update_schema
from harness.log.foxglove import LINE_LIST, LINE_STRIP
from harness.log.schemas import QUERY_SCHEMA
from harness.log.style import LEGEND, PARTIAL_STYLE, rgba, rgba8
from mpnet.envs import Workspace, get_spec
from mpnet.motion import verify_path
from mpnet.planners import EXACT, INVALID_QUERY, NO_SOLUTION, TIMEOUT, Problem
from mpnet.planners.base import PARTIAL_KINDS
from mpnet.planners.classical import OmplPlanner
from mpnet.planners.neural import MPNetPlanner

ou.setLogLevel(ou.LOG_WARN)
S2D = get_spec("s2d")
WALL = Workspace("wall", "file", [[0.0, 0.0]], [[4.0, 30.0]])
# A valid goal at the origin walled in on all four sides: no planner reaches it.
FREE = Workspace("free", "file", np.zeros((0, 2)), np.zeros((0, 2)))
RING = Workspace("ring", "file", [[0, 3], [0, -3], [3, 0], [-3, 0]], [[8, 2], [8, 2], [2, 8], [2, 8]])


def problem(ws, start, goal, **kw):
    return Problem(S2D, ws, S2D.make_checker(ws), np.array(start, float), np.array(goal, float), **kw)


def ring_problem():
    return problem(RING, (-10.0, -10.0), (0.0, 0.0), seed=3)


def mpnet(step, hybrid=False, replanning="original", **kw):
    base = "mpnet_hr" if hybrid else "mpnet_nr"
    return MPNetPlanner(
        base if replanning == "original" else f"{base}_{replanning}",
        encode=lambda cloud: np.zeros(4),
        step=step,
        cloud=lambda ws: S2D.cloud(ws, 200, 0),
        hybrid=hybrid,
        fallback=OmplPlanner("rrt_connect", "rrt_connect") if hybrid else None,
        replanning=replanning,
        **kw,
    )


def stuck(z, x, goal, rng):
    return x


def test_partial_kinds_have_a_style_and_the_legend_explains_them():
    assert set(PARTIAL_STYLE) == set(PARTIAL_KINDS)
    colors = [c for c, _, _ in PARTIAL_STYLE.values()]
    legend_colors = [c for _, c in LEGEND]
    assert len(set(legend_colors)) == len(legend_colors)  # every kind has a colour of its own
    assert all(c in legend_colors for c in colors)


# ------------------------------------------------------------------------ planners


@pytest.mark.parametrize("algorithm", ["rrt_connect", "rrt_star", "informed_rrt_star"])
def test_ompl_failure_carries_its_approximate_solution(algorithm):
    p = ring_problem()
    planner = OmplPlanner(algorithm, algorithm)
    warm_up(planner, p)  # as the bench does: 0.2 s spent loading the checker's kernels leaves no tree
    res = planner.solve(p, 0.2)
    assert res.status == TIMEOUT and res.path is None
    (approx,) = res.partial.values()
    assert list(res.partial) == ["approximate"]
    assert approx[0] == [-10.0, -10.0] and len(approx) >= 2
    assert all(p.checker.is_valid(q) for q in approx)  # the tree's states: all free
    d_end = np.linalg.norm(np.subtract(approx[-1], [0.0, 0.0]))
    assert d_end < np.linalg.norm([10.0, 10.0])  # it got nearer the goal


def test_ompl_partial_is_none_on_success_without_approximation_or_when_turned_off():
    solved = OmplPlanner("rrt_connect", "rrt_connect").solve(problem(WALL, (-10, 0), (10, 0), seed=1), 5.0)
    assert solved.status == EXACT and solved.partial is None
    assert OmplPlanner("bit_star", "bit_star").solve(ring_problem(), 0.2).partial is None  # BIT* keeps none
    off = OmplPlanner("rrt_connect", "rrt_connect", keep_partial=False).solve(ring_problem(), 0.2)
    assert off.status == TIMEOUT and off.partial is None
    bad = OmplPlanner("rrt_connect", "rrt_connect").solve(problem(WALL, (0, 0), (10, 0)), 1.0)
    assert bad.status == INVALID_QUERY and bad.partial is None


def test_ompl_stop_cost_failure_keeps_the_path_that_missed_the_target():
    p = problem(WALL, (-10, 0), (10, 0), seed=2, reference_cost=1.0)  # far below any path's cost
    res = OmplPlanner("bit_star", "bit_star", stop="cost").solve(p, 0.3)
    assert res.status == TIMEOUT and res.path is None
    path = res.partial["approximate"]
    assert path[0] == [-10.0, 0.0] and path[-1] == [10.0, 0.0]
    assert verify_path(S2D, WALL, path, p.start, p.goal) is None


def test_mpnet_first_run_that_does_not_connect_keeps_both_trees():
    """Algorithm 1: the first run fails after 80 steps; its two paths, 40 proposals each,
    rooted at the start and at the goal; no coarse path, so no last path."""
    p = problem(WALL, (-10, 0), (10, 0), seed=0)
    res = mpnet(stuck).solve(p, 5.0)
    assert res.status == NO_SOLUTION
    assert sorted(res.partial) == ["backward", "forward"]
    fwd, bwd = res.partial["forward"], res.partial["backward"]
    assert len(fwd) == len(bwd) == 41
    assert fwd[0] == [-10.0, 0.0] and bwd[0] == [10.0, 0.0]
    assert all(type(x) is float for q in fwd for x in q)  # plain copies, not the planner's arrays


def test_mpnet_replanning_failure_keeps_its_last_path_and_the_segment_trees():
    """The coarse path crosses the wall; replanning cannot connect that segment: the path
    as it stood (not feasible) and the trees of the segment's NeuralPlanner run."""
    p = problem(WALL, (-10, 0), (10, 0), seed=0)

    def through(z, x, goal, rng):  # the first proposal lands right of the wall; then stuck
        return np.array([5.0, 0.0]) if np.allclose(x, p.start) and goal[0] == 10.0 else x

    res = mpnet(through).solve(p, 5.0)
    assert res.status == NO_SOLUTION and res.stats["replans"] == 1
    last = res.partial["last_path"]
    assert last[0] == [-10.0, 0.0] and last[-1] == [10.0, 0.0] and [5.0, 0.0] in last
    assert not S2D.make_checker(WALL).motion_valid(last[0], last[1])  # not feasible
    fwd, bwd = res.partial["forward"], res.partial["backward"]
    assert len(fwd) + len(bwd) == 2 + 50  # the segment's run: 50 replanning steps
    assert fwd[0] == [-10.0, 0.0] and bwd[0] == [5.0, 0.0]  # the unconnectable segment's ends


def test_mpnet_hr_failure_keeps_the_path_its_fallback_could_not_complete():
    res = mpnet(stuck, hybrid=True, replanning="forgiving").solve(ring_problem(), 0.5)
    assert res.status == TIMEOUT and res.stats["fallback_used"]
    assert res.partial["last_path"] == [[-10.0, -10.0], [0.0, 0.0]]  # [start, goal], left to replanning
    assert "approximate" not in res.partial  # the fallback's own partial paths are not MPNet's


def test_mpnet_success_and_invalid_query_have_no_partial():
    def toward(z, x, goal, rng):  # straight at the other end: connects on a free line
        return x + 0.5 * (goal - x)

    ok = mpnet(toward).solve(problem(FREE, (-10, 0), (10, 0), seed=0), 5.0)
    assert ok.solved and ok.partial is None
    bad = mpnet(toward).solve(problem(WALL, (0, 0), (10, 0)), 5.0)
    assert bad.status == INVALID_QUERY and bad.partial is None


def test_untrained_mpnet_fails_with_its_partial_paths():
    """A real (tiny, untrained) Pnet through the numpy export cannot reach a walled-in goal."""
    import torch

    from mpnet.models.networks import Normalizer, Pnet, pnet_numpy

    torch.manual_seed(0)
    net = pnet_numpy(Pnet(4 + 2 * 2, 2, hidden=(16, 8)), Normalizer(20.0))

    def step(z, x, goal, rng):
        return np.asarray(net(z.astype(np.float32), x, goal, rng), float)

    res = mpnet(step, max_steps=20).solve(ring_problem(), 2.0)
    assert not res.solved and res.stats["replans"] == 10
    # Its trees connected every time, through a wall (tree edges are checked only by the
    # feasibility check); the last replanned path shows where.
    last = res.partial["last_path"]
    assert last[0] == [-10.0, -10.0] and last[-1] == [0.0, 0.0] and len(last) > 2
    assert not all(S2D.make_checker(RING).motion_valid(a, b) for a, b in zip(last[:-1], last[1:]))


# ------------------------------------------------------------------------ /query


def test_plan_query_logs_partial_for_failures_only_and_thins_it():
    failed = plan_query(mpnet(stuck), problem(WALL, (-10, 0), (10, 0), seed=0), 5.0)
    assert failed["failure"] == NO_SOLUTION and sorted(failed["partial"]) == ["backward", "forward"]
    toward = mpnet(lambda z, x, goal, rng: x + 0.5 * (goal - x))
    ok = plan_query(toward, problem(FREE, (-10, 0), (10, 0), seed=0), 5.0)
    assert ok["failure"] is None and ok["partial"] is None
    long = [[float(i), 0.0] for i in range(1000)]
    thin = logged_partial({"approximate": long, "forward": long[:3]})
    assert len(thin["approximate"]) == PARTIAL_MAX_STATES and thin["forward"] == long[:3]
    assert thin["approximate"][0] == long[0] and thin["approximate"][-1] == long[-1]
    assert logged_partial(None) is None and logged_partial({}) is None


STATES = [[-15.0, -15.0], [-5.0, -12.0], [0.0, -10.0]]
PARTIAL = {"forward": STATES, "backward": [[15.0, -15.0], [10.0, -12.0]], "last_path": STATES, "approximate": STATES}


def query(qid, success, partial=None):
    return {
        "query_id": qid,
        "workspace_id": "ws0",
        "split": "unseen",
        "start": [-15.0, -15.0],
        "goal": [15.0, -15.0],
        "success": success,
        "failure": None if success else "timeout",
        "path": [[-15.0, -15.0], [15.0, -15.0]] if success else [],
        "partial": partial,
        "time_s": 0.01,
        "cpu_s": 0.01,
        "path_cost": 30.0 if success else None,
        "collision_checks": 10,
    }


def write_log(run_dir, rerun=False):
    run = dict(
        env="s2d",
        planner="mpnet_nr",
        seed=0,
        split="seen+unseen",
        config="",
        git_rev=None,
        versions={},
        host="h",
        started_at="2026-11-21T12:00:00+00:00",
    )
    with TrialLog(run_dir, run, S2D, rerun=rerun, rerun_batch=2) as log:
        log.add_workspace(Workspace("ws0", "unseen", [[10.0, 10.0]], [[5.0, 5.0]]))
        log.add_query(query("ws0-0", True))
        log.add_query(query("ws0-1", False, PARTIAL))
        log.add_query(query("ws0-2", True))
    from harness.log import read_log

    msgs, _ = read_log(run_dir / "trials.mcap", ("/query", "/scene"))
    return [m.data for m in msgs if m.topic == "/query"], [m.data for m in msgs if m.topic == "/scene"]


def test_query_has_partial_for_the_failure_only_and_csv_leaves_it_out(tmp_path):
    queries, _ = write_log(tmp_path)
    for q in queries:
        jsonschema.validate(q, QUERY_SCHEMA)
    assert [q["partial"] for q in queries] == [None, PARTIAL, None]
    header = (tmp_path / "queries.csv").read_text().splitlines()[0].split(",")
    assert not [h for h in header if h.startswith("partial")]


def test_foxglove_scene_draws_partial_paths_labels_and_legend(tmp_path):
    _, scenes = write_log(tmp_path)
    for s in scenes:
        jsonschema.validate(s, scene_update_schema())
    ws_scene, *q_scenes = scenes
    legend = [e for e in ws_scene["entities"] if e["id"] == "legend"][0]
    assert [t["text"] for t in legend["texts"]] == [words for words, _ in LEGEND]
    assert [t["color"] for t in legend["texts"]] == [rgba(c) for _, c in LEGEND]
    ok, failed = q_scenes[0]["entities"][0], q_scenes[1]["entities"][0]
    assert len(ok["lines"]) == 1  # a success: its path only
    path, *partial = failed["lines"]
    assert path["points"] == []
    assert [ln["color"] for ln in partial] == [rgba(c) for c, _, _ in PARTIAL_STYLE.values()]
    by_color = {json.dumps(ln["color"]): ln for ln in partial}
    fwd = by_color[json.dumps(rgba(PARTIAL_STYLE["forward"][0]))]
    assert fwd["type"] == LINE_STRIP and [(p["x"], p["y"]) for p in fwd["points"]] == [tuple(q) for q in STATES]
    dashed = by_color[json.dumps(rgba(PARTIAL_STYLE["last_path"][0]))]
    assert dashed["type"] == LINE_LIST and len(dashed["points"]) % 2 == 0 and len(dashed["points"]) > 2
    for e in (ok, failed):  # labels and metadata carry planner and split
        (label,) = e["texts"]
        assert label["text"].startswith("mpnet_nr unseen ws0-")
        meta = {m["key"]: m["value"] for m in e["metadata"]}
        assert meta["planner"] == "mpnet_nr" and meta["split"] == "unseen"
    assert failed["texts"][0]["text"] == "mpnet_nr unseen ws0-1: timeout"


def test_rerun_recording_holds_the_partial_paths(tmp_path):
    write_log(tmp_path, rerun=True)
    from rerun.chunk import RrdReader

    rows: dict[str, dict] = {}
    for c in RrdReader(tmp_path / "trials.rrd").stream():
        path = str(c.entity_path)
        if c.is_empty or not (path.startswith("/scene/world/partial/") or path == "/scene/world/path"):
            continue
        rb = c.to_record_batch()
        cols = {n.split(":")[-1]: rb.column(n).to_pylist() for n in rb.schema.names if ":" in n}
        for i, t in enumerate(rb.column("query").to_pylist()):
            rows.setdefault(path, {})[t] = {k: v[i] for k, v in cols.items()}
    assert sorted(rows) == ["/scene/world/partial/" + k for k in sorted(PARTIAL_KINDS)] + ["/scene/world/path"]
    assert rows["/scene/world/path"][1]["labels"] == ["mpnet_nr unseen ws0-1: timeout"]
    for kind, (color, dashed, _) in PARTIAL_STYLE.items():
        r = rows["/scene/world/partial/" + kind]
        assert sorted(r) == [1, 2] and r[2]["strips"] == []  # the next success clears it
        assert r[1]["labels"] == [f"mpnet_nr unseen ws0-1: {kind}"]
        assert r[1]["colors"] == [int.from_bytes(bytes(rgba8(color)), "big")]
        strips = r[1]["strips"]
        assert len(strips) > 1 if dashed else strips == [PARTIAL[kind]]


def test_painters_draw_partial_paths_for_every_robot():
    import rerun as rr

    for env in ("s2d", "c3d", "rigid", "arm7"):
        spec = get_spec(env)
        p = painter_for(spec.robot_json(), spec.workspace_dim)
        a, b = np.zeros(spec.state_dim), np.full(spec.state_dim, 0.3)
        msg = {**query("q", False), "start": a.tolist(), "goal": b.tolist()}
        msg["partial"] = {"forward": [a.tolist(), b.tolist()], "last_path": [a.tolist(), b.tolist()], "odd": [[1.0]]}
        drawn = dict(p.partial_strips(msg))
        assert list(drawn) == ["forward", "last_path"]  # a kind with no style is left out
        assert all(s.shape[1] == spec.workspace_dim for strips in drawn.values() for s in strips)
        assert all(len(s) == 2 for s in drawn["last_path"])  # dashes
        names = [e for e, _, _ in p.rerun_partials(rr, [msg], "x", set())]
        assert names == ["scene/world/partial/forward", "scene/world/partial/last_path"]


def test_rerun_partial_rows_only_where_a_failure_draws_or_the_next_query_clears():
    import rerun as rr

    p = painter_for({"kind": "point"}, 2)
    fwd, approx = {"forward": STATES}, {"approximate": STATES}
    shown: set[str] = set()
    batch = [query("0", True), query("1", False, fwd), query("2", True), query("3", True), query("4", False, approx)]
    rows = {e.rsplit("/", 1)[1]: r for e, r, _ in p.rerun_partials(rr, batch, "x", shown)}
    assert rows == {"forward": [1, 2], "approximate": [4]} and shown == {"approximate"}
    rows = {e.rsplit("/", 1)[1]: r for e, r, _ in p.rerun_partials(rr, [query("5", True)], "x", shown)}
    assert rows == {"approximate": [0]} and shown == set()  # cleared at the next batch's first query
    assert p.rerun_partials(rr, [query("6", True)], "x", shown) == []  # successes alone: nothing sent


def test_logging_a_success_costs_no_more_than_before(tmp_path):
    """A success's partial is null: nothing is drawn and the scene stays small."""
    _, scenes = write_log(tmp_path)
    ok, failed = (len(json.dumps(s)) for s in scenes[1:3])
    assert ok < 2000 < failed


@pytest.mark.slow  # a subprocess
def test_a_run_with_failures_logs_and_draws_their_partial_paths(tmp_path, run_cli):
    """The bench end to end: RRT-Connect on a walled-in goal and a free query."""
    f = tmp_path / "ring.json"
    ring = {
        "id": "ring",
        "obstacles": [{"center": c, "size": s} for c, s in zip(RING.centers.tolist(), RING.sizes.tolist())],
    }
    ring["queries"] = [{"start": [-10.0, -10.0], "goal": [0.0, 0.0]}, {"start": [-15.0, 15.0], "goal": [15.0, 15.0]}]
    f.write_text(json.dumps({"format": "mpnet-bench/problems@1", "env": "s2d", "workspaces": [ring]}))
    t = time.perf_counter()
    run_cli(
        "harness",
        "+env=s2d",
        "+planner=rrt_connect",
        f"problems={f}",
        "budget_s=0.3",
        f"hydra.run.dir={tmp_path / 'r'}",
    )
    assert time.perf_counter() - t < 120
    from harness.log import read_log

    msgs, _ = read_log(tmp_path / "r" / "trials.mcap", ("/query",))
    failed, ok = (m.data for m in msgs)
    assert failed["failure"] == "timeout" and list(failed["partial"]) == ["approximate"]
    assert ok["success"] and ok["partial"] is None
    from rerun.chunk import RrdReader

    paths = {str(c.entity_path) for c in RrdReader(tmp_path / "r" / "trials.rrd").stream() if not c.is_empty}
    assert "/scene/world/partial/approximate" in paths
