"""The report's OMPL benchmark database (harness.report.arena): its rows from known logs, opened
with Planner Arena's own code, configs, segments and versions, variants and envs kept apart."""

from __future__ import annotations

import sqlite3

import numpy as np
import pandas as pd
import pytest

from harness.report import arena
from tests.harness.report._helpers import Q, report, write_log


@pytest.mark.slow  # the whole report, end to end
def test_benchmark_db(tmp_path, known):
    for _ in range(2):  # a second report replaces the database
        rc, out = report(tmp_path, known)
        assert rc == 0
    con = sqlite3.connect(out / "benchmark.db")
    names = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
    assert {"experiments", "plannerConfigs", "runs", "progress", "enums"} <= names
    assert con.execute("SELECT count(*) FROM runs").fetchone()[0] == 11
    experiments = con.execute("SELECT name, split FROM experiments ORDER BY id").fetchall()
    assert experiments == [("s2d", "seen"), ("s2d", "unseen")]
    planners = {r[0] for r in con.execute("SELECT name FROM plannerConfigs")}
    assert planners == {"geometric_mpnet_nr", "geometric_bit_star"}
    enums = dict(con.execute("SELECT description, value FROM enums WHERE name='status'"))
    cols = [r[1] for r in con.execute("PRAGMA table_info(runs)")]
    assert cols[:3] == ["id", "experimentid", "plannerid"]
    assert {"time", "solved", "status", "solution_length", "collision_checks", "pnet_calls"} <= set(cols)
    # Planner Arena plots every column of runs: numbers only, none NULL in every row
    assert not {"memory", "seed", "split", "workspace_id", "query_id", "failure"} & set(cols)
    for col in cols[3:]:
        assert con.execute(f"SELECT count(*) FROM runs WHERE typeof({col}) = 'text'").fetchone() == (0,), col
        assert con.execute(f"SELECT count({col}) FROM runs").fetchone()[0] > 0, col
    rows = con.execute(
        "SELECT r.solved, r.status, r.solution_length, r.time, q.failure, q.query_id FROM runs r "
        "JOIN run_queries q ON q.runid = r.id JOIN plannerConfigs p ON p.id = r.plannerid "
        "WHERE p.name = 'geometric_mpnet_nr' AND q.seed = 0 AND q.split = 'seen' ORDER BY q.query_id"
    ).fetchall()
    assert rows == [
        (1, enums["Exact solution"], 10.0, 0.1, None, "0/0"),
        (1, enums["Exact solution"], 20.0, 0.2, None, "0/1"),
        (1, enums["Exact solution"], 30.0, 0.3, None, "1/0"),
        (0, enums["Timeout"], None, 9.0, "timeout", "1/1"),
    ]
    no_solution = "SELECT r.status FROM runs r JOIN run_queries q ON q.runid = r.id WHERE q.failure = 'no_solution'"
    assert con.execute(no_solution).fetchone()[0] == enums["Abort"]
    assert con.execute("SELECT count(*) FROM run_queries").fetchone()[0] == 11
    # progress: BIT*'s logged best cost over time, sampled from 0 to each run's end; MPNet logs none
    prog = con.execute(
        "SELECT p.runid, p.time, p.best_cost, r.time FROM progress p JOIN runs r ON r.id = p.runid "
        "JOIN plannerConfigs c ON c.id = r.plannerid WHERE c.name = 'geometric_bit_star' ORDER BY p.runid, p.time"
    ).fetchall()
    assert con.execute("SELECT count(DISTINCT runid) FROM progress").fetchone()[0] == 4
    by_run = {}
    for runid, t, cost, end in prog:
        by_run.setdefault(runid, []).append((t, cost, end))
    for rows in by_run.values():
        end = rows[0][2]
        assert rows[0][:2] == (0.0, None) and rows[-1][0] == pytest.approx(end)
        costs = [c for _, c, _ in rows if c is not None]
        assert costs == sorted(costs, reverse=True) and costs[-1] in (12.0, 14.0)
        assert 1 < len(rows) <= arena.PROGRESS_SAMPLES + 2
    con.close()


def test_progress_rows_sample_the_best_cost_like_ompl():
    rows = arena.progress_rows(7, [[0.25, 9.0], [0.5, 8.0]], 1.1, 0.2, reference=4.0)
    assert rows == [
        (7, 0.0, None, None),
        (7, 0.2, None, None),
        (7, 0.4, 9.0, 2.25),
        (7, pytest.approx(0.6), 8.0, 2.0),
        (7, 0.8, 8.0, 2.0),
        (7, 1.0, 8.0, 2.0),
        (7, 1.1, 8.0, 2.0),
    ]
    assert arena.progress_rows(7, [], 1.0, 0.1) == []
    assert arena.progress_rows(7, [[0.3, 5.0]], 0.2, 0.1)[-1] == (7, 0.3, 5.0, None)  # after the clock's end
    assert arena.progress_rows(7, [[0.3, 5.0]], 0.2, 0.1, float("nan"))[-1] == (7, 0.3, 5.0, None)
    assert arena.progress_period([0.5, 2.0]) == 2.0 / arena.PROGRESS_SAMPLES


@pytest.mark.slow  # the whole report, end to end, and Planner Arena's plots
def test_benchmark_db_opens_in_planner_arena(tmp_path, known):
    """Planner Arena's own loading code and the performance page's data and plots, for every
    attribute it offers, with the split as a problem parameter (aggregated, separate, one)."""
    pytest.importorskip("plannerarena")
    import matplotlib
    import polars as pl
    from plannerarena import performance as page
    from plannerarena.database import load_database
    from plannerarena.widgets import (
        PROBLEM_PARAMETERS_AGGREGATE_TEXT,
        PROBLEM_PARAMETERS_SEPARATE_TEXT,
        problem_parameter_filter,
        problem_parameter_groups,
        problem_parameter_widgets,
    )

    matplotlib.use("Agg")
    rc, out = report(tmp_path, known)
    assert rc == 0
    db = load_database(out / "benchmark.db")
    assert db["problem_names"] == ["s2d"] and db["parameters"] == ["split"]
    assert problem_parameter_widgets(db["experiments"], db["parameters"]) is not None
    assert db["attributes"][:4] == ["time", "solved", "status", "approximate solution"]
    runs = db["runs"].filter(pl.col("experiment") == "s2d")
    assert runs.height == 11 and set(runs["planner"].cast(pl.String)) == {"mpnet_nr", "bit_star"}
    statuses = runs.join(db["enums"], left_on="status", right_on="value")["description"]
    assert statuses.len() == 11 and "Unknown status" not in statuses.to_list()
    for split in (PROBLEM_PARAMETERS_AGGREGATE_TEXT, PROBLEM_PARAMETERS_SEPARATE_TEXT, "seen"):
        params = {"split": split}
        grouping = problem_parameter_groups(params)
        df = problem_parameter_filter(runs, params)
        if grouping:  # as the page does: the parameter as an ordered category
            df = df.with_columns(pl.col(grouping).cast(pl.String).cast(pl.Enum(sorted(df[grouping].unique()))))
        for attr in db["attributes"]:
            assert df[attr].dtype.is_numeric() and df[attr].null_count() < df.height, attr
            enums = db["enums"].filter(pl.col("name") == attr)
            plots = [page.enums_plot(df, enums, grouping)] if len(enums) else []
            plots += (
                [] if len(enums) else [page.boxplot(df, attr, grouping, "o", False), page.ecdf_plot(df, attr, grouping)]
            )
            for plot in plots:
                fig = plot.draw()
                assert all(np.isfinite(ax.get_ylim()).all() for ax in fig.axes), attr
                matplotlib.pyplot.close(fig)
            missing = (
                df.with_columns(pl.col(attr).is_null().alias("missing"))
                .group_by("planner")
                .agg(pl.col("missing").sum(), pl.len().alias("total"))
            )
            assert missing["total"].sum() == df.height
    # the progress page: its attribute list, its data and its plot, built as progress_server
    # builds them (the split aggregated and separate; one chosen split errors in 1.0.1's page)
    import plotnine as p9

    assert db["progress"].columns[2:] == ["best cost", "best quality"]  # its names for best_cost, ...
    for split in (PROBLEM_PARAMETERS_AGGREGATE_TEXT, PROBLEM_PARAMETERS_SEPARATE_TEXT):
        params = {"split": split}
        grouping = problem_parameter_groups(params)
        df = problem_parameter_filter(
            db["progress"].join(runs.select(["id", "planner", grouping]), left_on="runid", right_on="id"), params
        )
        if grouping:
            df = df.with_columns(pl.col(grouping).cast(pl.String).cast(pl.Enum(sorted(df[grouping].unique()))))
        assert set(df["planner"].cast(pl.String)) == {"bit_star"}
        for attr in db["progress"].columns[2:]:
            assert df[attr].null_count() < df.height, attr
            plot = p9.ggplot(df, p9.aes(x="time", y=attr, color="planner", fill="planner")) + p9.geom_smooth(
                na_rm=True, method="loess", span=0.1, se=False
            )
            if grouping:
                plot = plot + p9.scale_linetype(name=grouping)
            count = p9.ggplot(df, p9.aes(x="time", color="planner")) + p9.geom_freqpoly(binwidth=1)
            for p in (plot + p9.geom_point(), count):
                fig = p.draw()
                assert all(np.isfinite(ax.get_ylim()).all() for ax in fig.axes), attr
                matplotlib.pyplot.close(fig)


@pytest.mark.slow  # the whole report, end to end
def test_benchmark_db_configs_segments_versions(tmp_path):
    logs = tmp_path / "logs"
    write_log(
        logs / "b0",
        "s2d",
        "bit_star",
        0,
        [Q("seen", "0", 0, True, 1.0), Q("seen", "0", 1, False, 9.0), Q("seen", "0", 2, True, 1.0, stats={"path": []})],
    )
    write_log(
        logs / "b1",
        "s2d",
        "bit_star",
        1,
        [Q("seen", "0", 0, True, 1.0)],
        config="budget_s: 10.0\nplanner:\n  name: bit_star\n  range: 2.0\n",
    )
    write_log(logs / "b2", "s2d", "bit_star", 2, [Q("seen", "0", 0, True, 1.0)])
    write_log(logs / "c", "c2d", "bit_star", 0, [Q("seen", "0", 0, True, 1.0)], versions={"ompl": "1.6.0"})
    rc, out = report(tmp_path, logs)
    assert rc == 0
    con = sqlite3.connect(out / "benchmark.db")
    configs = con.execute("SELECT id, name, settings FROM plannerConfigs ORDER BY id").fetchall()
    assert sorted("range: 2.0" in st for _, n, st in configs) == [False, True]
    names = [n for _, n, _ in configs]  # two variants, two names (a log without settings: its config's digest)
    assert len(set(names)) == 2 and all(n.startswith("geometric_bit_star [planner.config=") for n in names)
    seeds_of = dict(
        con.execute(
            "SELECT p.settings, group_concat(DISTINCT q.seed) FROM runs r JOIN run_queries q ON q.runid = r.id "
            "JOIN plannerConfigs p ON p.id = r.plannerid GROUP BY p.id"
        )
    )
    assert sorted(seeds_of.values()) == ["0,2", "1"]
    rows = con.execute(
        "SELECT q.query_id, r.solved, r.solution_segments FROM runs r JOIN run_queries q ON q.runid = r.id "
        "JOIN experiments e ON e.id = r.experimentid WHERE e.name = 's2d' AND e.split = 'seen' AND q.seed = 0 "
        "ORDER BY q.query_id"
    ).fetchall()
    assert rows == [("0/0", 1, 2), ("0/1", 0, None), ("0/2", 1, None)]
    assert con.execute("SELECT count(*) FROM runs WHERE solution_segments < 0").fetchone() == (0,)
    assert dict(con.execute("SELECT name, version FROM experiments")) == {
        "s2d": "OMPL 2.0.1",
        "c2d": "OMPL 1.6.0",
    }
    con.close()


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_benchmark_db_keeps_variants_apart(tmp_path):
    """One planner run with two checkers, and on a subset of the same problems: each variant is
    a planner of its own, named by the settings that differ, and none has more runs than its
    experiment's runcount (each query and seed once). Before, RRT-Connect with spheres and with
    pybullet was one planner of 1,400 runs in an experiment of 700."""
    logs = tmp_path / "logs"
    settings = {"seed": 0, "budget_s": 10.0, "planner.name": "rrt_connect", "problems": "sha256:" + "a" * 64}
    every = [Q("seen", "0", i, True, 1.0) for i in range(4)]
    write_log(logs / "sp", "s2d", "rrt_connect", 0, every, settings={**settings, "env.collision": "spheres"})
    write_log(logs / "pb", "s2d", "rrt_connect", 0, every, settings={**settings, "env.collision": "pybullet"})
    subset = {**settings, "env.collision": "spheres", "problems": "sha256:" + "b" * 64}
    write_log(logs / "first2", "s2d", "rrt_connect", 0, every[:2], settings=subset)
    write_log(
        logs / "seed1", "s2d", "rrt_connect", 1, every, settings={**settings, "seed": 1, "env.collision": "spheres"}
    )
    rc, out = report(tmp_path, logs)
    assert rc == 0
    con = sqlite3.connect(out / "benchmark.db")
    runs = dict(
        con.execute("SELECT p.name, count(*) FROM runs r JOIN plannerConfigs p ON p.id = r.plannerid GROUP BY p.id")
    )
    assert runs == {
        "geometric_rrt_connect [env.collision=spheres, problems=aaaaaaaa]": 8,  # seeds 0 and 1: one variant
        "geometric_rrt_connect [env.collision=pybullet, problems=aaaaaaaa]": 4,
        "geometric_rrt_connect [env.collision=spheres, problems=bbbbbbbb]": 2,
    }
    assert con.execute("SELECT runcount FROM experiments").fetchall() == [(8,)]  # 4 queries x 2 seeds
    con.close()
    # the tables keep them apart by the same names: results.csv once pooled both checkers' runs
    # in one row of 1,400 queries (reports/archive/arm7_mbm, with only a warning)
    res = pd.read_csv(out / "results.csv").set_index("planner")["queries"].to_dict()
    assert res == {
        "rrt_connect [env.collision=spheres, problems=aaaaaaaa]": 8,
        "rrt_connect [env.collision=pybullet, problems=aaaaaaaa]": 4,
        "rrt_connect [env.collision=spheres, problems=bbbbbbbb]": 2,
    }


@pytest.mark.slow  # the whole report, end to end
def test_benchmark_db_keeps_labelled_runs_apart(tmp_path):
    """Runs given with --label (two revisions of one planner, the same settings) are planners of
    their own in the database, as in the tables: before, both were one planner of 1,400 runs in an
    experiment of 700 (reports/rrt_connect_compiled/cloud, caught by test_committed_reports)."""
    settings = {"seed": 0, "budget_s": 10.0, "planner.name": "mpnet_nr"}
    every = [Q("seen", "0", i, True, 1.0) for i in range(4)]
    write_log(tmp_path / "before", "s2d", "mpnet_nr", 0, every, settings=settings)
    write_log(tmp_path / "after", "s2d", "mpnet_nr", 0, every, settings=settings)
    rc, out = report(tmp_path, labels=[("before", tmp_path / "before"), ("after", tmp_path / "after")])
    assert rc == 0
    con = sqlite3.connect(out / "benchmark.db")
    runs = dict(
        con.execute("SELECT p.name, count(*) FROM runs r JOIN plannerConfigs p ON p.id = r.plannerid GROUP BY p.id")
    )
    assert runs == {"geometric_mpnet_nr [before]": 4, "geometric_mpnet_nr [after]": 4}
    assert con.execute("SELECT runcount FROM experiments").fetchall() == [(4,)]
    con.close()
    assert set(pd.read_csv(out / "results.csv")["planner"]) == {"mpnet_nr [before]", "mpnet_nr [after]"}


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_benchmark_db_names_a_planner_in_two_envs_plainly(tmp_path):
    """Planner Arena groups runs by name within an experiment (an env), so one planner's runs in
    two envs are not variants of each other: each env's runs are named `bit_star`. Before, every
    run of a multi-env report whose log carried its settings was named `bit_star [env.name=s2d]`
    (and the equal-quality planners by every env setting), which hid them from the committed
    database test's check of the optimizing planners' progress."""
    logs = tmp_path / "logs"
    every = [Q("seen", "0", i, True, 1.0) for i in range(2)]
    for env in ("s2d", "c2d"):
        settings = {"seed": 0, "budget_s": 10.0, "planner.name": "bit_star", "env.name": env}
        write_log(logs / env, env, "bit_star", 0, every, settings=settings)
    rc, out = report(tmp_path, logs)
    assert rc == 0
    con = sqlite3.connect(out / "benchmark.db")
    names = {n for (n,) in con.execute("SELECT name FROM plannerConfigs")}
    con.close()
    assert names == {"geometric_bit_star"}
