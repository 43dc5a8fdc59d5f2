"""The report's figures (harness.report.figures): the example query chosen, success against
time, cost/CPU/checks over every success, stale figures removed, the problem sets' figures."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from harness.report.figures import pick_example, solved_within, success_vs_time
from harness.report.load import load, queries_frame
from harness.report.stats import wilson
from tests.harness.report._helpers import Q, report, write_log


@pytest.mark.slow  # the whole report, end to end
def test_figures_and_example_choice(tmp_path, capsys):
    logs = tmp_path / "logs"
    for env in ("rigid", "c3d"):
        # query 0/0: only BIT* solved it; 0/1: both did (the example); 0/2: both did, later
        write_log(
            logs / env / "nr",
            env,
            "mpnet_nr",
            0,
            [Q("seen", "0", 0, False, 1.0), Q("seen", "0", 1, True, 0.1), Q("seen", "0", 2, True, 0.1)],
        )
        write_log(logs / env / "bit", env, "bit_star", 0, [Q("seen", "0", k, True, 1.0) for k in range(3)])
    rc, out = report(tmp_path, logs)
    assert rc == 0 and capsys.readouterr().err == ""
    names = {p.name for p in (out / "figures").iterdir()}
    for fig in ("success", "success_vs_time", "time_boxplot", "example_rigid", "example_c3d"):
        assert {fig + ".png", fig + ".svg"} <= names
    files, _, _ = load([logs])
    q = queries_frame(files)
    chosen, ref = pick_example(q, "rigid")
    assert set(chosen) == {"mpnet_nr", "bit_star"} and q.at[ref, "query_id"] == "0/1"
    assert {q.at[r, "query_id"] for r in chosen.values()} == {"0/1"}


@pytest.mark.slow  # the whole report, end to end
def test_cost_cpu_checks_over_every_success(tmp_path):
    """A success without a logged time is left out of the time statistics only."""
    logs = tmp_path / "logs"
    write_log(
        logs / "nr",
        "s2d",
        "mpnet_nr",
        0,
        [
            Q("seen", "0", 0, True, 0.1, cost=10.0, checks=10),
            Q("seen", "0", 1, True, None, cost=30.0, checks=30, stats={"cpu_s": 0.5}),
            Q("seen", "0", 2, False, 9.0, checks=999),
        ],
    )
    rc, out = report(tmp_path, logs)
    assert rc == 0
    r = pd.read_csv(out / "results.csv").iloc[0]
    assert (r["successes"], r["success_mean"]) == (2, pytest.approx(2 / 3))
    assert (r["time_mean_s"], r["time_std_s"], r["time_median_s"]) == (pytest.approx(0.1), 0.0, pytest.approx(0.1))
    assert r["cost_mean"] == pytest.approx(20.0)
    assert r["cpu_mean_s"] == pytest.approx(0.3)
    assert r["collision_checks_median"] == pytest.approx(20.0)


@pytest.mark.slow  # the whole report, end to end
def test_stale_figures_are_removed(tmp_path):
    logs = tmp_path / "logs"
    write_log(logs / "s", "s2d", "bit_star", 0, [Q("seen", "0", 0, True, 1.0)])
    write_log(logs / "c", "c2d", "bit_star", 0, [Q("seen", "0", 0, True, 1.0)])
    rc, out = report(tmp_path, logs)
    assert rc == 0 and (out / "figures" / "example_c2d.svg").exists()
    (out / "figures" / "notes.txt").write_text("mine")
    (out / "figures" / "perf_growth.png").write_text("another tool's figure")
    (out / "figures" / "time_per_planner.svg").write_text("an older report's figure")
    rc, out = report(tmp_path, logs / "s")
    names = {p.name for p in (out / "figures").iterdir()}
    assert rc == 0 and "example_s2d.png" in names and {"notes.txt", "perf_growth.png"} <= names
    assert "time_per_planner.svg" not in names
    assert not {"example_c2d.png", "example_c2d.svg"} & names


def test_success_vs_time_numbers():
    """The share solved within a budget counts successes with time <= budget over all queries
    (failures and successes without a time included), with the Wilson interval at each budget."""
    curve = solved_within([0.3, 0.1, 0.2, math.nan], 5, [0.05, 0.1, 0.25, 10.0])
    assert curve["solved"].tolist() == [0, 1, 2, 3] and curve["share"].tolist() == [0.0, 0.2, 0.4, 0.6]
    for k, lo, hi in zip(curve["solved"], curve["ci_low"], curve["ci_high"]):
        assert (lo, hi) == pytest.approx(wilson(k, 5), abs=1e-12)
    q = pd.DataFrame(
        {
            "env": "s2d",
            "split": "seen",
            "planner": ["a", "a", "a", "b", "b"],
            "success": [True, True, False, True, False],
            "time_s": [0.5, 0.1, 9.0, 2.0, 8.0],
        }
    )
    c = success_vs_time(q).set_index(["planner", "budget_s"])
    assert c.loc["a", "solved"].to_dict() == {0.1: 1, 0.5: 2, 9.0: 2}
    assert c.loc["b", "share"].to_dict() == {2.0: 0.5, 9.0: 0.5}
    assert (c["n"].to_dict()[("a", 9.0)], c["n"].to_dict()[("b", 9.0)]) == (3, 2)


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_problem_sets_count_valid_and_solved_per_scene_with_published_figures(tmp_path):
    """A MotionBenchMaker-style problem-file run: per set, invalid queries are not valid,
    timeouts and their CPU share are counted, and the published VAMP/cuRobo figures follow."""
    logs = tmp_path / "logs"
    queries = [
        Q("file", "box_panda/0001", 0, True, 0.2),
        Q("file", "box_panda/0002", 0, False, 0.01, failure="invalid_query"),
        Q("file", "cage_panda/0001", 0, False, 10.0, stats={"cpu_s": 9.5}),
        Q("file", "cage_panda/0002", 0, True, 0.4),
    ]
    write_log(logs / "rrtc", "arm7", "rrt_connect", 0, queries, split="file")
    rc, out = report(tmp_path, logs)
    assert rc == 0
    ps = pd.read_csv(out / "problem_sets.csv").set_index("problem_set")
    assert ps.loc["box_panda", ["total", "valid", "solved", "timeouts"]].tolist() == [2, 1, 1, 0]
    assert ps.loc["cage_panda", ["total", "valid", "solved", "timeouts"]].tolist() == [2, 2, 1, 1]
    assert ps.loc["cage_panda", "timeout_cpu_share"] == pytest.approx(0.95)
    md = (out / "problem_sets.md").read_text()
    assert "1 (95.0)" in md and "VAMP" in md and "cuRobo" in md
