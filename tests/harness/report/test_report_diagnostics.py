"""The report's diagnostics table and the learning curve, from known logs."""

from __future__ import annotations

import math

import pytest
import yaml

from harness.log.facts import facts_from_config
from harness.report.diagnostics import diagnostics_table, render_diagnostics
from harness.report.learning_curve import learning_curve_table, main, train_size
from harness.report.load import load
from harness.report.stats import wilson
from tests.harness.report._helpers import Q, planner_section, write_log


def diag(props, first=0, replan=None, bad=0, out=0, reach=0, first_valid=True, shift=None, spread=1.0):
    d = {
        "proposals": props,
        "proposals_first": first if replan is None else props - replan,
        "proposals_replan": replan if replan is not None else props - first,
        "proposals_in_collision": bad,
        "proposals_out_of_bounds": out,
        "proposals_reachable": reach,
        "first_valid": first_valid,
        "first_visible_from_start": reach > 0,
        "first_visible_to_goal": False,
        "dropout_spread": spread,
    }
    if shift is not None:
        d["code_shift"] = shift
    return {"diagnostics": d, "pnet_calls": props}


def config(workspaces: int, paths: int, planner: str = "mpnet_nr") -> str:
    return yaml.safe_dump(
        {
            "budget_s": 10.0,
            "scale": {"train": {"workspaces": workspaces, "paths": paths}},
            "planner": planner_section(planner),
        }
    )


def test_diagnostics_table_known_answers(tmp_path):
    write_log(
        tmp_path / "a",
        "s2d",
        "mpnet_nr",
        0,
        [
            Q("seen", "0", 0, True, 0.01, stats=diag(10, first=4, bad=5, out=1, reach=2, shift=0.5, spread=2.0)),
            Q(
                "seen",
                "1",
                0,
                False,
                0.01,
                stats=diag(30, first=80 - 50, bad=10, reach=3, first_valid=False, shift=1.5),
            ),
        ],
    )
    write_log(tmp_path / "b", "s2d", "bit_star", 0, [Q("seen", "0", 0, True, 0.01)])
    files, _, _ = load([tmp_path])
    df = diagnostics_table(files)
    assert list(df["planner"]) == ["mpnet_nr"]  # BIT* logs no diagnostics
    r = df.iloc[0]
    assert r["queries"] == 2 and r["success"] == 0.5
    assert r["proposals_per_query"] == 20 and r["first_run_calls"] == 17 and r["replan_calls"] == 3
    assert r["in_collision"] == pytest.approx(15 / 40) and r["out_of_bounds"] == pytest.approx(1 / 40)
    assert r["reachable"] == pytest.approx(5 / 40) and r["first_valid"] == 0.5
    assert r["code_shift"] == 1.0 and r["dropout_spread"] == 1.5
    md = render_diagnostics(df)
    assert "| s2d | seen | mpnet_nr | 2 | 50.0% | 20.0 (17.0 + 3.0) | 37.5% | 2.5% | 12.5% | 50.0% |" in md


def test_failures_by_where_they_end(tmp_path):
    """Each failed valid query is counted once, at the step of Algorithm 1 it stopped at; a
    success or an invalid query is no failure; the run's replan_rounds says when the rounds ran out."""

    def fail(replans, failure="no_solution", fallback=False):
        return {**diag(5), "replans": replans, "fallback_used": fallback, "failure": failure}

    queries = [
        Q("seen", "0", 0, True, 0.01, stats={**diag(4), "replans": 2}),
        Q("seen", "0", 1, False, 0.01, stats=fail(0)),  # first run did not connect
        Q("seen", "0", 2, False, 0.01, stats=fail(3)),  # stuck in round 3
        Q("seen", "0", 3, False, 0.01, stats=fail(10)),  # every round ran
        Q("seen", "0", 4, False, 0.01, stats=fail(10)),
        Q("seen", "0", 5, False, 10.0, stats=fail(4, failure="timeout")),
        Q("seen", "0", 6, False, 0.01, stats=fail(1, fallback=True)),  # HR's planner did not complete it
        Q("seen", "0", 7, False, 0.0, stats={**diag(0), "failure": "invalid_query"}),
    ]
    write_log(tmp_path / "a", "s2d", "mpnet_nr", 0, queries, settings={"planner.replan_rounds": 10})
    files, _, _ = load([tmp_path])
    r = diagnostics_table(files).iloc[0]
    assert r["queries"] == 8 and r["failed"] == 6
    got = {k: r[k] for k in ("fail_first_run", "fail_stuck", "fail_rounds", "fail_fallback", "fail_timeout")}
    assert got == {"fail_first_run": 1, "fail_stuck": 1, "fail_rounds": 2, "fail_fallback": 1, "fail_timeout": 1}
    md = render_diagnostics(diagnostics_table(files))
    assert "| s2d | seen | mpnet_nr | 6 | 1 (17%) | 1 (17%) | 2 (33%) | 1 (17%) | 1 (17%) |" in md


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_learning_curve_by_training_size(tmp_path, capsys):
    sizes = {(100, 10): [True] * 3 + [False], (100, 40): [True] * 4, (25, 160): [False, True]}
    for (w, p), oks in sizes.items():
        for planner in ("mpnet_nr", "mpnet_nr_random"):
            write_log(
                tmp_path / f"{w}x{p}" / planner,
                "s2d",
                planner,
                0,
                [Q("unseen", "100", i, ok, 0.01, stats=diag(4, first=4, bad=1)) for i, ok in enumerate(oks)],
                config=config(w, p, planner),
            )
    write_log(tmp_path / "nosize", "s2d", "mpnet_nr", 0, [Q("unseen", "100", 0, True, 0.01)])
    files, _, _ = load([tmp_path])
    df, warns = learning_curve_table(files)
    assert len(warns) == 1 and "nosize" in warns[0] and "scale.train" in warns[0]
    nr = df[df["planner"] == "mpnet_nr"]
    assert list(nr["train_paths"]) == [1000, 4000, 4000] and list(nr["train_workspaces"]) == [100, 25, 100]
    row = nr[(nr["train_workspaces"] == 100) & (nr["paths_per_workspace"] == 10)].iloc[0]
    assert row["success"] == 0.75 and (row["success_ci_low"], row["success_ci_high"]) == pytest.approx(wilson(3, 4))
    assert row["in_collision"] == 0.25 and math.isnan(row["code_shift"])
    assert train_size({"config": config(7, 9)}) == (7, 9) and train_size({"config": "budget_s: 1"}) is None
    out = tmp_path / "lc"
    assert main([str(tmp_path), "--out", str(out)]) == 0
    for name in ("learning_curve.md", "learning_curve.csv", "learning_curve.png", "learning_curve.svg"):
        assert (out / name).stat().st_size > 0
    assert "| s2d | unseen | mpnet_nr | 1000 (100 × 10) | 4 | 75.0 [" in (out / "learning_curve.md").read_text()
    assert main([str(tmp_path / "nothing"), "--out", str(out)]) == 1
    assert "error: no trial logs" in capsys.readouterr().err


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_learning_curve_sizes_are_the_paths_built(tmp_path):
    """Issue 26: a panda_mbm dataset holds fewer paths than workspaces x paths asked (cage goals
    can fail); a size is the count a run of it logged (`training_paths_built`), for every
    planner at that size, the random ablation too, which plans on no network."""
    for planner, built in (("mpnet_nr", 950), ("mpnet_nr_random", None)):
        cfg = config(100, 10, planner)
        facts = {**facts_from_config(yaml.safe_load(cfg)), "training_paths_built": built}
        write_log(tmp_path / planner, "s2d", planner, 0, [Q("unseen", "100", 0, True, 0.01)], config=cfg, facts=facts)
    write_log(tmp_path / "older", "s2d", "mpnet_nr", 0, [Q("unseen", "100", 0, True, 0.01)], config=config(100, 40))
    files, _, _ = load([tmp_path])
    df, _ = learning_curve_table(files)
    assert sorted(zip(df["planner"], df["train_paths"])) == [
        ("mpnet_nr", 950),
        ("mpnet_nr", 4000),  # a log without the count: the size asked
        ("mpnet_nr_random", 950),
    ]
    main([str(tmp_path), "--out", str(tmp_path / "lc")])
    assert "| 950 (100 × 10) |" in (tmp_path / "lc" / "learning_curve.md").read_text()
