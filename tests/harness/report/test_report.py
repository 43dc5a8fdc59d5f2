"""`python -m harness.report` (docs/reports.md): statistics from known logs, Table I with
and without the paper's numbers, figures, the OMPL benchmark database, bad files."""

from __future__ import annotations

import math
import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from mcap.reader import make_reader
from mcap.writer import Writer

from harness.core.cli import CONF_DIR
from harness.log import TrialLog, read_log, run_segments
from harness.report import arena
from harness.report.__main__ import main
from harness.report.facts import Facts, planner_facts, run_facts
from harness.report.figures import pick_example, solved_within, success_vs_time
from harness.report.load import load, queries_frame
from harness.report.names import env_rank
from harness.report.readme import judge_bullet
from harness.report.stats import BOOT_N, boot_interval, boot_medians, fisher_p, wilson
from mpnet.envs.spaces import SE2Space
from mpnet.envs.specs import SPECS
from mpnet.envs.workspace import Workspace


def planner_section(name: str) -> dict:
    """The `planner` section conf/planner/<name>.yaml resolves to (its defaults list merged as Hydra
    does for these files), as a run logs it in its config."""
    raw = yaml.safe_load((CONF_DIR / "planner" / f"{name}.yaml").read_text())
    defaults = raw.pop("defaults", ["_self_"])
    out = {}
    for d in defaults if "_self_" in defaults else defaults + ["_self_"]:
        if d == "_self_":
            out.update(raw)
        else:
            parent, _, key = d.partition("@")
            out.update({key: planner_section(parent)} if key else planner_section(parent))
    return out


def planner_config(conf: str, **planner_kw) -> str:
    """A run's resolved config as YAML text: a budget and the planner section of conf/planner/<conf>.yaml
    (a bare `name: <conf>` for a planner not there), with planner_kw on top."""
    known = (CONF_DIR / "planner" / f"{conf}.yaml").exists()
    section = {**(planner_section(conf) if known else {"name": conf}), **planner_kw}
    return yaml.safe_dump({"budget_s": 10.0, "planner": section}, sort_keys=False)


def ws(env: str, wid: str, split: str) -> Workspace:
    wd = SPECS[env].workspace_dim
    return Workspace(wid, split, np.array([[0.0] * wd, [10.0] * wd]), np.array([[4.0] * wd, [3.0] * wd]))


def write_log(
    run_dir: Path,
    env: str,
    planner: str,
    seed,
    queries: list[dict],
    config: str | None = None,
    resume: bool = False,
    **run_kw,
) -> Path:
    """A trials.mcap with the given queries: dicts with split, wid, i, ok, t, and optional
    cost, checks and planner stats (any query field); paths run start -> (0, 15) -> goal."""
    spec = SPECS[env]
    d = spec.state_dim
    run = {
        "env": env,
        "planner": planner,
        "seed": seed,
        "split": "seen+unseen",
        "config": config or planner_config(planner),
        "git_rev": "abc1234",
        "versions": {"ompl": "2.0.1"},
        "host": "testhost",
        "started_at": "2026-11-21T12:00:00+00:00",
        **run_kw,
    }
    with TrialLog(run_dir, run, spec, rerun=False, resume=resume) as log:
        for q in queries:
            log.add_workspace(ws(env, q["wid"], q["split"]))
            start, mid, goal = np.full(d, -15.0), np.zeros(d), np.full(d, 15.0)
            mid[1] = 15.0
            if isinstance(spec.space, SE2Space):
                start[2], mid[2], goal[2] = 0.0, 1.0, 0.5
            rec = dict(
                query_id=f"{q['wid']}/{q['i']}",
                workspace_id=q["wid"],
                split=q["split"],
                start=start,
                goal=goal,
                success=q["ok"],
                failure=None if q["ok"] else q.get("failure", "timeout"),
                path=[start, mid, goal] if q["ok"] else [],
                time_s=q["t"],
                cpu_s=q["t"],
                path_cost=q.get("cost", 50.0) if q["ok"] else None,
                collision_checks=q.get("checks", 100),
                state_checks=1,
                motion_checks=1,
            )
            rec.update(q.get("stats", {}))
            log.add_query(rec)
    return run_dir / "trials.mcap"


def Q(split, wid, i, ok, t, **kw):
    return dict(split=split, wid=wid, i=i, ok=ok, t=t, **kw)


def report(tmp_path, *dirs, paper=False):
    out = tmp_path / "out"
    rc = main([str(d) for d in dirs] + ["--out", str(out)] + (["--paper"] if paper else []))
    return rc, out


@pytest.fixture()
def known(tmp_path):
    """s2d: mpnet_nr seeds 0 and 1, bit_star seed 0 logged twice (two files)."""
    logs = tmp_path / "logs"
    nr = {"pnet_calls": 4, "replans": 1, "fallback_used": False}
    write_log(
        logs / "nr0",
        "s2d",
        "mpnet_nr",
        0,
        [
            Q("seen", "0", 0, True, 0.1, cost=10.0, checks=10, stats=nr),
            Q("seen", "0", 1, True, 0.2, cost=20.0, checks=20, stats={**nr, "pnet_calls": 6, "replans": 0}),
            Q("seen", "1", 0, True, 0.3, cost=30.0, checks=30, stats={**nr, "fallback_used": True}),
            Q("seen", "1", 1, False, 9.0, checks=999, stats=nr),
            Q("unseen", "100", 0, True, 0.5, cost=5.0, stats=nr),
        ],
    )
    write_log(
        logs / "nr1",
        "s2d",
        "mpnet_nr",
        1,
        [
            Q("seen", "0", 0, True, 0.4, cost=40.0, checks=40, stats=nr),
            Q("seen", "0", 1, False, 1.0, failure="no_solution", stats=nr),
        ],
    )
    ref = {"reference_cost": 10.0}  # BIT* logs its best cost over time; with a reference, quality too
    for k in ("a", "b"):
        write_log(
            logs / k / "bit0",
            "s2d",
            "bit_star",
            0,
            [
                Q("seen", "0", 0, True, 2.0, cost=12.0, stats={"progress": [[0.5, 20.0], [1.5, 12.0]], **ref}),
                Q("seen", "0", 1, True, 3.0, cost=14.0, stats={"progress": [[1.0, 14.0]], **ref}),
            ],
        )
    return logs


@pytest.mark.slow  # the whole report, end to end
def test_statistics_exact(tmp_path, known, capsys):
    rc, out = report(tmp_path, known)
    assert rc == 0
    cap = capsys.readouterr()
    assert "read 4 trial logs" in cap.out and "skipped 0" in cap.out
    # bit_star seed 0 is logged twice: counted twice, with one warning naming both files
    dup = (
        f"warning: s2d bit_star seed 0: 2 queries logged in more than one file, all counted: "
        f"{known / 'a' / 'bit0' / 'trials.mcap'}, {known / 'b' / 'bit0' / 'trials.mcap'}"
    )
    assert cap.err.strip().splitlines() == [dup]
    readme = (out / "README.md").read_text()
    assert "## Warnings" in readme and dup.removeprefix("warning: ") in readme
    res = pd.read_csv(out / "results.csv", keep_default_na=False, na_values=[""])
    assert list(zip(res["split"], res["planner"])) == [
        ("seen", "mpnet_nr"),
        ("seen", "bit_star"),
        ("unseen", "mpnet_nr"),
    ]
    nr = res.iloc[0]
    assert (nr["env"], nr["queries"], nr["seeds"], nr["successes"]) == ("s2d", 6, 2, 4)
    assert nr["success_mean"] == pytest.approx(0.625)  # seeds: 3/4 and 1/2
    assert nr["success_std"] == pytest.approx(0.25 / math.sqrt(2))  # ddof=1 over 2 seeds
    assert nr["time_mean_s"] == pytest.approx(0.25)  # successes 0.1 .. 0.4
    assert nr["time_std_s"] == pytest.approx(np.std([0.1, 0.2, 0.3, 0.4], ddof=1))
    assert nr["time_median_s"] == pytest.approx(0.25)
    assert nr["time_p90_s"] == pytest.approx(0.37)
    assert nr["cost_mean"] == pytest.approx(25.0)
    assert nr["collision_checks_median"] == pytest.approx(25.0)
    assert nr["pnet_calls_median"] == pytest.approx(4.0)  # over all 6 queries
    assert nr["replans_mean"] == pytest.approx(5 / 6)
    assert nr["fallback_rate"] == pytest.approx(1 / 6)
    assert nr["failures"] == "no_solution: 1; timeout: 1"
    bit = res.iloc[1]  # one seed, two files
    assert (bit["queries"], bit["seeds"], bit["success_mean"], bit["success_std"]) == (4, 1, 1.0, 0.0)
    assert bit["time_mean_s"] == pytest.approx(2.5) and bit["cost_mean"] == pytest.approx(13.0)
    assert math.isnan(bit["pnet_calls_median"]) and math.isnan(bit["fallback_rate"])
    un = res.iloc[2]
    assert (un["queries"], un["seeds"], un["success_std"], un["time_std_s"]) == (1, 1, 0.0, 0.0)

    # logs without reference_cost, ablations or time-to-equal-quality runs: blanks, no crash
    assert nr["success_rate"] == pytest.approx(4 / 6)
    assert (nr["success_ci_low"], nr["success_ci_high"]) == pytest.approx(wilson_by_hand(4, 6))
    assert nr["time_median_ci_low"] <= nr["time_median_s"] <= nr["time_median_ci_high"]
    assert nr["quality_n"] == 0 and math.isnan(nr["quality_median"]) and math.isnan(nr["quality_p90"])
    # NR seed 0 costs 10, 20 against bit_star seed 0's 12, 14 (NR seed 1 has no BIT* pair)
    assert nr["cost_over_bit_star_n"] == 2
    assert nr["cost_over_bit_star_median"] == pytest.approx((10 / 12 + 20 / 14) / 2)
    assert bit["cost_over_bit_star_n"] == 0 and math.isnan(bit["cost_over_bit_star_median"])
    assert (bit["comparator"], bit["success_diff_significant"]) == ("mpnet_nr", False)
    assert bit["success_p_vs"] == pytest.approx(0.4666667)  # Fisher: 4/4 against 4/6
    assert bit["time_diff_significant"] and bit["time_ratio_vs"] == pytest.approx(10.0)
    assert isinstance(nr["comparator"], float) and math.isnan(nr["comparator"])  # NR: no comparator
    assert (out / "quality.csv").exists() and not (out / "ablations.md").exists()
    assert not (out / "equal_quality.md").exists()
    assert "`ablations.*`: not written" in readme and "`equal_quality.*`: not written" in readme

    t1 = pd.read_csv(out / "table1.csv")
    assert list(t1["split"]) == ["seen", "unseen"] and set(t1["source"]) == {"ours"}
    row = t1.iloc[0]
    assert row["mpnet_nr_time_mean_s"] == pytest.approx(0.25)
    assert row["bit_star_over_mpnet_nr"] == pytest.approx(10.0)
    assert math.isnan(row["mpnet_hr_time_mean_s"]) and math.isnan(t1.iloc[1]["bit_star_over_mpnet_nr"])
    md = (out / "table1.md").read_text()
    assert "| Simple 2D | seen | 0.250 ± 0.129 |  |  | 2.50 ± 0.58 | 10.0 |" in md
    assert "The clock: MPNet's planning loop and RRT-Connect (compiled) call the collision kernels" in md
    # the checks beside the times: NR's solved queries took 10, 20, 30, 40 checks, BIT*'s none logged
    assert "## Collision checks a solved query" in md and "| Simple 2D | seen | 25.0 |" in md
    sc = (out / "success_cost.md").read_text()
    # pooled 4/6 = 66.7% with its Wilson interval [30.0, 90.3]
    assert "| Simple 2D | seen | MPNet (NR) | 62.5 ± 17.7 | 66.7 [30.0, 90.3] | 25.0 | 6 | 2 |" in sc
    assert "ddof=1" in (out / "README.md").read_text()


@pytest.mark.slow  # the whole report, end to end
def test_only_some_planners_blank_cells_and_paper(tmp_path, capsys):
    logs = tmp_path / "logs"
    write_log(logs / "b", "c2d", "bit_star", 0, [Q("unseen", "100", 0, True, 0.002)])
    write_log(logs / "r", "c2d", "rrt_connect", 0, [Q("unseen", "100", 0, True, 0.001)])
    write_log(logs / "i", "c2d", "informed_rrt_star", 0, [Q("unseen", "100", 0, False, 10.0)])
    rc, out = report(tmp_path, logs)
    assert rc == 0
    assert (
        "| Complex 2D | unseen | Informed-RRT* | 0.0 ± 0.0 | 0.0 [0.0, 79.3] |  | 1 | 1 |"
        in (out / "success_cost.md").read_text()
    )
    md = (out / "table1.md").read_text()
    # the paper's layout first (its four planners, the ratio), then the other planners;
    # a planner that ran and solved nothing reads "— (0/N)", one not run is blank
    head = "| Env | Split | MPNet (NR) | MPNet (HR) | Informed-RRT* | BIT* | BIT*/MPNet (NR) | RRT-Connect |"
    assert head in md
    assert "| Complex 2D | unseen |  |  | — (0/1) | 0.00200 ± 0.00000 |  | 0.00100 ± 0.00000 |" in md
    assert "— (0/N)" in md and "blank: the planner was not run" in md
    assert "arXiv:1806.05767" in md and "paper" not in md.split("\n\n")[1]
    assert list(pd.read_csv(out / "table1.csv").columns) == [
        "env",
        "split",
        "source",
        "mpnet_nr_time_mean_s",
        "mpnet_nr_time_std_s",
        "mpnet_hr_time_mean_s",
        "mpnet_hr_time_std_s",
        "informed_rrt_star_time_mean_s",
        "informed_rrt_star_time_std_s",
        "bit_star_time_mean_s",
        "bit_star_time_std_s",
        "bit_star_over_mpnet_nr",
        "rrt_connect_time_mean_s",
        "rrt_connect_time_std_s",
    ]
    assert "--- (0/1)" in (out / "table1.tex").read_text()

    rc, out = report(tmp_path, logs, paper=True)
    assert rc == 0
    md = (out / "table1.md").read_text()
    assert "| Env | Split | Source |" in md
    assert "|  |  | paper | 0.18 ± 0.27 | 0.68 ± 0.41 | 6.31 ± 0.85 | 4.12 ± 1.99 | 22.9 |  |" in md
    assert "Python implementations" in md
    tex = (out / "table1.tex").read_text()
    for cmd in (r"\toprule", r"\midrule", r"\bottomrule", r"$\pm$", "arXiv:1806.05767"):
        assert cmd in tex
    t1 = pd.read_csv(out / "table1.csv")
    assert list(t1["source"]) == ["ours", "paper"]
    assert t1.iloc[1]["bit_star_time_mean_s"] == pytest.approx(4.12)
    assert (out / "success_cost.tex").read_text().count(r"\bottomrule") == 1


@pytest.mark.slow  # the whole report, end to end
def test_paper_numbers_as_printed(tmp_path):
    """--paper shows the paper's numbers exactly as harness/report/paper_table1.csv gives them."""
    logs = tmp_path / "logs"
    write_log(logs / "nr", "rigid", "mpnet_nr", 0, [Q("seen", "0", 0, True, 0.5)])
    write_log(logs / "s", "s2d", "mpnet_nr", 0, [Q("seen", "0", 0, True, 0.5)])
    rc, out = report(tmp_path, logs, paper=True)
    assert rc == 0
    md = (out / "table1.md").read_text()
    assert "|  |  | paper | 0.32 ± 0.28 | 1.92 ± 1.30 | 30.25 ± 27.59 | 11.10 ± 5.59 | 34.7 |" in md
    assert "|  |  | paper | 0.11 ± 0.037 | 0.19 ± 0.14 | 5.36 ± 0.34 | 2.71 ± 1.72 | 24.6 |" in md
    assert "ratio of the paper's mean times, computed here" in md
    tex = (out / "table1.tex").read_text()
    assert r"30.25 $\pm$ 27.59 & 11.10 $\pm$ 5.59 & 34.7" in tex


@pytest.mark.slow  # the whole report, end to end
def test_bad_files_are_skipped_with_one_warning_each(tmp_path, known, capsys):
    good = write_log(
        tmp_path / "logs" / "extra", "s2d", "bit_star", 1, [Q("seen", "0", k, True, 0.1) for k in range(20)]
    )
    data = good.read_bytes()
    with open(good, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    cut = chunks[len(chunks) // 2].chunk_start_offset + 20  # mid-chunk, halfway through the queries
    bad = tmp_path / "logs" / "bad"
    (bad / "truncated").mkdir(parents=True)
    (bad / "truncated" / "trials.mcap").write_bytes(data[:cut])
    (bad / "garbage").mkdir()
    (bad / "garbage" / "trials.mcap").write_bytes(os.urandom(5000))
    (bad / "empty").mkdir()
    (bad / "empty" / "trials.mcap").write_bytes(b"")
    (bad / "norun").mkdir()
    with open(bad / "norun" / "trials.mcap", "wb") as f:  # a valid MCAP file without /run
        w = Writer(f)
        w.start()
        ch = w.register_channel("/query", "json", w.register_schema("x", "jsonschema", b"{}"))
        w.add_message(ch, 1, b'{"query_id": "0"}', 1)
        w.finish()
    rc, out = report(tmp_path, tmp_path / "logs")
    cap = capsys.readouterr()
    assert rc == 0 and "Traceback" not in cap.err
    lines = cap.err.strip().splitlines()
    dups = [ln for ln in lines if "logged in more than one file" in ln]  # bit_star seeds 0 and 1
    assert len(dups) == 2 and str(bad / "truncated" / "trials.mcap") in dups[1]
    lines = [ln for ln in lines if ln not in dups]
    assert len(lines) == 4
    for name in ("truncated", "garbage", "empty", "norun"):
        assert sum(str(bad / name / "trials.mcap") in ln for ln in lines) == 1
    assert "skipped 3" in cap.out
    res = pd.read_csv(out / "results.csv")
    bit = res[(res["planner"] == "bit_star") & (res["split"] == "seen")].iloc[0]
    # the 4 known queries, the 20 of the good extra file, and what the truncated copy kept
    assert 24 <= bit["queries"] < 44 and bit["seeds"] == 2


@pytest.mark.slow  # subprocesses
def test_no_readable_files_exit_1(tmp_path, repo):
    (tmp_path / "empty").mkdir()
    (tmp_path / "junk" / "x").mkdir(parents=True)
    (tmp_path / "junk" / "x" / "trials.mcap").write_bytes(b"not an mcap file")
    for d, n_lines in ((tmp_path / "empty", 1), (tmp_path / "junk", 2)):
        p = subprocess.run(
            [sys.executable, "-m", "harness.report", str(d), "--out", str(tmp_path / "out")],
            cwd=repo,
            check=False,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert p.returncode == 1 and "Traceback" not in p.stderr and p.stdout == ""
        lines = p.stderr.strip().splitlines()
        assert len(lines) == n_lines and lines[-1].startswith("error: no readable trials.mcap")
    assert not (tmp_path / "out").exists()


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


@pytest.mark.slow  # the whole report, end to end
def test_files_without_queries(tmp_path, capsys):
    logs = tmp_path / "logs"
    empty = write_log(logs / "empty", "s2d", "bit_star", 0, [])
    rc, out = report(tmp_path, logs)
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert rc == 1 and cap.out == "" and not out.exists()
    assert lines[0] == f"warning: {empty}: no queries"
    assert len(lines) == 2 and lines[1].startswith("error: no queries in the 1 readable trials.mcap")

    write_log(logs / "full", "s2d", "bit_star", 1, [Q("seen", "0", 0, True, 1.0)])
    rc, out = report(tmp_path, logs)
    assert rc == 0 and capsys.readouterr().err.strip().splitlines() == [f"warning: {empty}: no queries"]
    assert f"- {empty}: no queries" in (out / "README.md").read_text()


@pytest.mark.slow  # the whole report, end to end
def test_files_without_an_integer_seed_are_seeds_of_their_own(tmp_path, capsys):
    logs = tmp_path / "logs"
    write_log(logs / "a", "s2d", "bit_star", None, [Q("seen", "0", 0, True, 1.0)])
    write_log(logs / "b", "s2d", "bit_star", "seven", [Q("seen", "0", 0, False, 9.0)])
    write_log(logs / "c", "s2d", "bit_star", 0, [Q("seen", "0", 0, True, 2.0)])
    rc, out = report(tmp_path, logs)
    lines = capsys.readouterr().err.strip().splitlines()
    assert rc == 0 and len(lines) == 2
    assert lines[0].startswith(f"warning: {logs / 'a' / 'trials.mcap'}: its /run has no integer seed (None)")
    assert lines[1].startswith(f"warning: {logs / 'b' / 'trials.mcap'}: its /run has no integer seed ('seven')")
    r = pd.read_csv(out / "results.csv").iloc[0]
    assert (r["queries"], r["seeds"], r["success_mean"]) == (3, 3, pytest.approx(2 / 3))
    con = sqlite3.connect(out / "benchmark.db")
    assert sorted(con.execute("SELECT seed FROM run_queries").fetchall(), key=str) == [(0,), (None,), (None,)]
    assert con.execute("SELECT seed FROM experiments").fetchone() == ("0",)
    con.close()


@pytest.mark.slow  # the whole report, end to end
def test_readme_scales_and_no_warnings(tmp_path, capsys):
    logs = tmp_path / "logs"
    quick = (
        "budget_s: 10.0\nscale:\n  name: quick\n  test:\n    seen: {workspaces: 20, queries: 10}\n"
        "    unseen: {workspaces: 10, queries: 20}\n  train: {workspaces: 100, paths: 40}\n"
        "  model: {pnet_hidden: [512, 256, 128, 64]}\nplanner:\n  name: bit_star\n"
    )
    write_log(logs / "q", "s2d", "bit_star", 0, [Q("seen", "0", 0, True, 1.0)], config=quick)
    write_log(
        logs / "p",
        "s2d",
        "mpnet_nr",
        0,
        [Q("seen", "0", 0, True, 1.0)],
        config="budget_s: 10.0\nscale:\n  name: paper\nplanner:\n  name: mpnet_nr\n",
    )
    write_log(
        logs / "o",
        "s2d",
        "rrt_star",
        0,
        [Q("seen", "0", 0, True, 1.0)],
        config="budget_s: 10.0\nscale:\n  name: mine\nplanner:\n  name: rrt_star\n",
    )
    rc, out = report(tmp_path, logs)
    assert rc == 0 and capsys.readouterr().err == ""
    readme = (out / "README.md").read_text()
    assert "## Warnings" in readme and readme.split("## Warnings")[1].split("##")[0].strip().endswith("none")
    assert (
        "- Our `quick` scale trains smaller networks on 100 workspaces × 40 expert paths and tests on "
        "200 seen + 200 unseen queries per seed; the paper: 100 × 4000 paths; 100 × 200 seen, "
        "10 × 2000 unseen."
    ) in readme
    assert "- Scale `paper`: the paper's sizes." in readme
    judged = "fine re-check (s2d: every 0.01 along the path, a point against the boxes, exact)"
    assert judged in " ".join(readme.split())
    assert "- Scale `mine`: smaller than the paper's." in readme


def wilson_by_hand(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    p = k / n
    centre, half = (p + z * z / (2 * n)) / (1 + z * z / n), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return centre - half / (1 + z * z / n), centre + half / (1 + z * z / n)


def test_wilson_fisher_bootstrap_known_values():
    assert wilson(3, 4) == pytest.approx(wilson_by_hand(3, 4))
    assert wilson(0, 1) == pytest.approx((0.0, wilson_by_hand(0, 1)[1]))
    assert all(math.isnan(x) for x in wilson(0, 0))
    # hypergeometric by hand: margins 5 / 5 of 10, P(x) = C(5, x)^2 / 252; |x - 2.5| >= 1.5
    assert fisher_p(4, 5, 1, 5) == pytest.approx(52 / 252)
    assert fisher_p(3, 4, 1, 4) == pytest.approx(34 / 70)
    assert math.isnan(fisher_p(1, 1, 0, 0))
    # the order-statistic bootstrap has the distribution of medians of resamples drawn with replacement
    brute = np.random.default_rng(1)
    for x in ([1.0, 2.0, 3.0, 4.0, 10.0], [1.0, 2.0, 3.0, 4.0, 5.0, 7.0], [0.5, 0.5, 2.0, np.inf]):
        fast = boot_medians(x, ("test", len(x)))
        slow = np.median(brute.choice(x, (BOOT_N, len(x))), axis=1)
        assert len(fast) == BOOT_N and set(fast) <= set(slow) | {np.inf}
        for v in sorted(set(slow)):
            assert np.mean(fast == v) == pytest.approx(np.mean(slow == v), abs=0.02)
        assert np.array_equal(fast, boot_medians(x, ("test", len(x))))  # seeded: reproducible
    assert boot_interval(boot_medians([0.5] * 5, ("c",))) == (0.5, 0.5)
    assert boot_medians([], ("e",)) is None and all(math.isnan(v) for v in boot_interval(None))
    lo, hi = boot_interval(boot_medians([1.0, np.inf, np.inf], ("inf",)))
    assert lo == 1.0 and hi == np.inf


def test_planner_names():
    """Comparators, labels and order follow what each name's config (conf/planner) says it is."""
    names = [
        "bit_star_to_nr",
        "mpnet_hr_random",
        "mpnet_nr_zeros",
        "mpnet_nr_random",
        "rrt_star",
        "bit_star",
        "mpnet_nr",
    ]
    more = ["mpnet_hr", "mpnet_hr_zeros", "mpnet_hr_nodropout", "informed_rrt_star_to_nr_x1.1"]
    facts = Facts({n: run_facts({"planner": n, "config": planner_config(n)}) for n in names + more})
    assert facts.comparator("mpnet_nr") is None and facts.comparator("mpnet_hr") == "mpnet_nr"
    assert facts.comparator("mpnet_nr_zeros") == "mpnet_nr" and facts.comparator("mpnet_hr_zeros") == "mpnet_hr"
    assert facts.comparator("bit_star") == "mpnet_nr"
    assert facts.label("mpnet_hr_nodropout") == "MPNet (HR): nodropout"
    assert facts.label("informed_rrt_star_to_nr_x1.1") == "Informed-RRT* to NR ×1.1"
    assert facts.label("bit_star_to_nr") == "BIT* to NR"
    assert sorted(names, key=facts.rank) == [
        "mpnet_nr",
        "bit_star",
        "rrt_star",
        "mpnet_nr_random",
        "mpnet_nr_zeros",
        "mpnet_hr_random",
        "bit_star_to_nr",
    ]
    # a name alone says nothing: without facts, every one of them is a plain planner
    assert Facts().ablation("mpnet_nr_zeros") is None and Facts().equal_quality("bit_star_to_nr") is None


def test_a_recipe_labelled_planner_is_compared_with_its_own_planner_on_the_envs_recipe():
    """`mpnet_nr [dagger2]` (a label its networks' recipe gave, load.recipe_label) compares with
    mpnet_nr, not with itself (its significance was p = 1 against itself); an HR variant with
    the paper's recipe with the same HR variant on the env's; a --label keeps its own label's base."""
    from harness.report.facts import PlannerFacts

    nr, hrc = PlannerFacts("mpnet_nr"), PlannerFacts("mpnet_hr", "rrtc")
    by = {
        "mpnet_nr": nr,
        "mpnet_nr [dagger2]": PlannerFacts("mpnet_nr", "dagger2"),
        "mpnet_nr_paper [paper_recipe]": PlannerFacts("mpnet_nr", "paper_recipe"),
        "mpnet_nr [pairs_uniform]": nr,
        "mpnet_hr_rrtc": hrc,
        "mpnet_hr_rrtc [paper_recipe]": PlannerFacts("mpnet_hr", "paper_recipe+rrtc"),
        "mpnet_nr_random [first10]": PlannerFacts("mpnet_nr", "random"),
        "mpnet_nr [first10]": nr,
    }
    tags = {n: (n.split(" [")[0], n.split(" [")[1][:-1] if " [" in n else None) for n in by}
    recipes = [n for n in by if " [" in n and "first10" not in n]
    facts = Facts(by, tags, recipes=recipes)
    assert facts.comparator("mpnet_nr [dagger2]") == "mpnet_nr"
    assert facts.comparator("mpnet_nr_paper [paper_recipe]") == "mpnet_nr"
    assert facts.comparator("mpnet_nr [pairs_uniform]") == "mpnet_nr"
    assert facts.comparator("mpnet_hr_rrtc [paper_recipe]") == "mpnet_hr_rrtc"
    assert facts.comparator("mpnet_nr_random [first10]") == "mpnet_nr [first10]"
    assert facts.comparator("mpnet_nr [first10]") is None
    assert (
        Facts({"mpnet_nr [dagger2]": by["mpnet_nr [dagger2]"]}, recipes=["mpnet_nr [dagger2]"]).comparator(
            "mpnet_nr [dagger2]"
        )
        is None
    )  # no run of the env's recipe: nothing to compare with


@pytest.mark.slow  # the whole report, end to end
def test_facts_come_from_the_run_config(tmp_path, capsys):
    """What a planner is comes from its /run config, whatever its name: keys of old configs and of
    configs without `_target_` / `needs_models` give the same facts; no readable config: a plain planner."""

    def facts(conf, **kw):
        return run_facts({"planner": kw.get("name", conf), "config": planner_config(conf, **kw)})

    assert facts("mpnet_nr", name="whatever", proposal="random").ablation == ("mpnet_nr", "random")
    assert facts("mpnet_hr", proposal="straight", dropout=False).ablation == ("mpnet_hr", "straight+nodropout")
    assert facts("mpnet_hr").ablation is None and facts("mpnet_hr").base == "mpnet_hr"
    assert facts("mpnet_hr_rrtc").ablation == ("mpnet_hr", "rrtc")
    assert facts("mpnet_nr_dense").ablation == ("mpnet_nr", "dense")
    assert facts("mpnet_hr_dense").ablation == ("mpnet_hr", "dense")
    assert facts("bit_star_to_nr_x1.1").equal_quality == ("bit_star", "nr", 1.1)
    assert facts("rrt_star", cost_target={"hybrid": True}, cost_factor=1.5).equal_quality == ("rrt_star", "hr", 1.5)
    new_style = {k: v for k, v in planner_section("mpnet_nr_zeros").items() if k != "needs_models"}
    new_style["_target_"] = "mpnet.somewhere.else"
    assert run_facts({"planner": "x", "config": yaml.safe_dump({"planner": new_style})}).ablation == (
        "mpnet_nr",
        "zeros",
    )
    assert facts("bit_star", name="mpnet_nr_random").ablation is None  # the name does not count
    assert run_facts({"planner": "x", "config": "planner: [unclosed"}) is None

    logs = tmp_path / "logs"
    write_log(logs / "nr", "s2d", "mpnet_nr", 0, [Q("seen", "0", i, True, 0.1) for i in range(3)])
    write_log(
        logs / "fancy",
        "s2d",
        "fancy",
        0,
        [Q("seen", "0", i, i > 0, 0.2) for i in range(3)],
        config=planner_config("mpnet_nr", name="fancy", proposal="random"),
    )
    write_log(
        logs / "chase",
        "s2d",
        "chase",
        0,
        [Q("seen", "0", i, True, 0.3, cost=10.0, stats={"target_cost": 10.0, "target_time_s": 0.1}) for i in range(3)],
        config=planner_config("bit_star_to_nr_x1.1", name="chase"),
    )
    write_log(
        logs / "broken",
        "s2d",
        "mpnet_nr_zeros",
        0,
        [Q("seen", "0", 0, True, 0.4)],
        config="budget_s: 10.0\nplanner: [unclosed\n",
    )
    rc, out = report(tmp_path, logs)
    err = capsys.readouterr().err
    assert rc == 0 and "Traceback" not in err
    assert err.strip().splitlines() == [
        f"warning: {logs / 'broken' / 'trials.mcap'}: its /run has no readable "
        "config with a planner section: mpnet_nr_zeros counted as a plain planner"
    ]
    res = pd.read_csv(out / "results.csv")
    assert list(res["planner"]) == ["mpnet_nr", "mpnet_nr_zeros", "fancy"]  # chase: equal_quality.csv
    assert res.set_index("planner").loc["fancy", "comparator"] == "mpnet_nr"
    ab = pd.read_csv(out / "ablations.csv", keep_default_na=False)
    assert list(zip(ab["planner"], ab["base"], ab["variant"])) == [
        ("mpnet_nr", "mpnet_nr", ""),
        ("fancy", "mpnet_nr", "random"),
    ]
    assert "| MPNet (NR): random | a uniformly random valid state" in (out / "ablations.md").read_text()
    assert "fancy" not in pd.read_csv(out / "table1.csv").columns.str.cat()
    assert "mpnet_nr_zeros_time_mean_s" in pd.read_csv(out / "table1.csv").columns  # plain: a column of its own
    eq = pd.read_csv(out / "equal_quality.csv")
    assert list(zip(eq["planner"], eq["algorithm"], eq["factor"], eq["target_planner"], eq["reached"])) == [
        ("chase", "bit_star", 1.1, "mpnet_nr", 3)
    ]
    files, _, _ = load([logs])
    assert planner_facts(files)[0].equal_quality("chase") == ("bit_star", "nr", 1.1)


def eq_config(name: str, factor: float | None = None) -> str:
    return planner_config(name) if factor is None else planner_config(name, cost_factor=factor)


@pytest.fixture()
def quality_logs(tmp_path):
    """s2d seen: MPNet (NR), (HR), Informed-RRT*, BIT* with reference costs, two ablations, and
    two time-to-equal-quality runs; rigid: one run with a planned reference."""
    logs = tmp_path / "qlogs"

    def ref(r):
        return {"reference_cost": r}

    write_log(
        logs / "nr",
        "s2d",
        "mpnet_nr",
        0,
        [
            Q("seen", "0", 0, True, 0.1, cost=11.0, stats=ref(10.0)),  # quality 1.1
            Q("seen", "0", 1, True, 0.2, cost=26.0, stats=ref(20.0)),  # 1.3
            Q("seen", "0", 2, True, 0.3, cost=48.0, stats=ref(30.0)),  # 1.6
            Q("seen", "0", 3, False, 9.0, stats=ref(40.0)),
            Q("seen", "0", 4, True, 0.2, cost=5.0),
        ],
    )  # no reference: not in quality
    write_log(
        logs / "bit0",
        "s2d",
        "bit_star",
        0,
        [
            Q("seen", "0", 0, True, 0.1, cost=10.0),
            Q("seen", "0", 1, True, 0.2, cost=20.0),
            Q("seen", "0", 2, False, 9.0),
            Q("seen", "0", 3, True, 0.3, cost=5.0),
            Q("seen", "0", 4, False, 9.0),
        ],
    )
    write_log(logs / "bit1", "s2d", "bit_star", 1, [Q("seen", "0", 0, True, 0.2, cost=100.0)])  # no NR seed 1
    write_log(logs / "irrt", "s2d", "informed_rrt_star", 0, [Q("seen", "0", i, True, 5.0 + i) for i in range(5)])
    write_log(logs / "hr", "s2d", "mpnet_hr", 0, [Q("seen", "0", i, True, 0.5) for i in range(5)])
    write_log(logs / "hr_zeros", "s2d", "mpnet_hr_zeros", 0, [Q("seen", "0", i, True, 0.5) for i in range(5)])
    write_log(
        logs / "nr_random",
        "s2d",
        "mpnet_nr_random",
        0,
        [Q("seen", "0", 0, True, 1.0, cost=10.0, stats=ref(10.0))]
        + [Q("seen", "0", i, False, 9.0) for i in range(1, 5)],
    )

    def target(cost, t):
        return {"target_planner": "mpnet_nr", "target_cost": cost, "target_time_s": t}

    no_target = Q("seen", "0", 3, False, 0.0, failure="no_target", stats=target(None, 0.5))
    write_log(
        logs / "to_nr",
        "s2d",
        "bit_star_to_nr",
        0,
        [  # factor from the config: 1.0
            Q("seen", "0", 0, True, 1.0, cost=9.9, stats=target(10.0, 0.1)),
            Q("seen", "0", 1, True, 2.0, cost=20.0, stats=target(20.0, 0.3)),
            Q("seen", "0", 2, False, 10.0, stats=target(30.0, 0.2)),
            no_target,
        ],
        config=eq_config("bit_star_to_nr"),
    )
    write_log(
        logs / "to_nr_x",
        "s2d",
        "bit_star_to_nr_x1.1",
        0,
        [  # factor from the config: 1.1
            Q("seen", "0", 0, True, 0.5, cost=10.9, stats=target(10.0, 0.1)),
            Q("seen", "0", 1, True, 9.0, cost=25.0, stats=target(20.0, 0.3)),  # above 1.1 x 20: a miss
            Q("seen", "0", 2, False, 10.0, stats=target(30.0, 0.2)),
            no_target,
        ],
        config=eq_config("bit_star_to_nr_x1.1", 1.1),
    )
    rigid_cfg = (
        "budget_s: 10.0\nenv:\n  name: rigid\n  expert: {iterations: 2000}\n  reference: {bit_star_s: 1.0}\n"
        "planner:\n  name: bit_star\n"
    )
    write_log(
        logs / "rigid",
        "rigid",
        "bit_star",
        0,
        [Q("seen", "0", 0, True, 0.1, cost=9.0, stats=ref(10.0))],
        config=rigid_cfg,
    )
    return logs


@pytest.mark.slow  # the whole report, end to end
def test_quality_ablations_equal_quality(tmp_path, quality_logs, capsys):
    rc, out = report(tmp_path, quality_logs)
    assert rc == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        (
            "warning: bit_star_to_nr_x1.1: 1 of its logged successes have a path cost above factor x "
            "target cost: counted as not reaching the target"
        )
    ]
    res = pd.read_csv(out / "results.csv")
    s2d = res[res["env"] == "s2d"].set_index("planner")
    # the time-to-equal-quality runs are not rows of results.csv; the ablations are, after the others
    assert list(s2d.index) == [
        "mpnet_nr",
        "mpnet_hr",
        "informed_rrt_star",
        "bit_star",
        "mpnet_nr_random",
        "mpnet_hr_zeros",
    ]
    nr, bit, rnd, hrz = s2d.loc["mpnet_nr"], s2d.loc["bit_star"], s2d.loc["mpnet_nr_random"], s2d.loc["mpnet_hr_zeros"]
    for r in s2d.itertuples():  # every success rate has its interval
        assert (r.success_ci_low, r.success_ci_high) == pytest.approx(wilson_by_hand(r.successes, r.queries))
    assert (nr["successes"], nr["queries"]) == (4, 5) and (bit["successes"], bit["queries"]) == (4, 6)
    assert (nr["quality_n"], nr["quality_median"], nr["quality_p90"]) == (
        3,
        pytest.approx(1.3),
        pytest.approx(1.3 + 0.8 * 0.3),
    )
    assert (nr["cost_over_bit_star_n"], nr["cost_over_bit_star_median"]) == (2, pytest.approx(1.2))
    assert (rnd["quality_n"], rnd["quality_median"], rnd["cost_over_bit_star_median"]) == (1, 1.0, 1.0)
    assert bit["quality_n"] == 0 and math.isnan(bit["cost_over_bit_star_median"])
    assert res[res["env"] == "rigid"].iloc[0]["quality_median"] == pytest.approx(0.9)
    # significance against the comparator
    assert rnd["comparator"] == "mpnet_nr" and rnd["success_p_vs"] == pytest.approx(52 / 252)
    assert not rnd["success_diff_significant"] and rnd["time_diff_significant"]
    assert rnd["time_ratio_vs"] == pytest.approx(5.0) and rnd["time_ratio_vs_ci_low"] > 1
    assert hrz["comparator"] == "mpnet_hr" and (
        hrz["time_ratio_vs"],
        hrz["time_ratio_vs_ci_low"],
        hrz["time_ratio_vs_ci_high"],
    ) == (1.0, 1.0, 1.0)
    assert not hrz["time_diff_significant"] and (hrz["time_median_ci_low"], hrz["time_median_ci_high"]) == (0.5, 0.5)
    assert not bit["time_diff_significant"] and bit["time_ratio_vs_ci_low"] < 1 < bit["time_ratio_vs_ci_high"]
    assert s2d.loc["informed_rrt_star", "time_diff_significant"] and s2d.loc["mpnet_hr", "comparator"] == "mpnet_nr"

    md = (out / "table1.md").read_text()  # BIT*'s median time and the ratio: not significant
    assert "| Simple 2D | seen | 0.200 ± 0.082 | 0.500 ± 0.000 | 7.00 ± 1.58 | ≈ 0.200 ± 0.082 | ≈ 1.00 |" in md
    assert "random" not in md and "to NR" not in md and "≈ before a time" in md
    assert r"$\approx$ 1.00" in (out / "table1.tex").read_text()
    assert set(pd.read_csv(out / "success_cost.csv")["planner"]) == {
        "mpnet_nr",
        "mpnet_hr",
        "informed_rrt_star",
        "bit_star",
    }
    sc = (out / "success_cost.md").read_text()
    assert "|  |  | Informed-RRT* | ≈ 100.0 ± 0.0 | 100.0 [56.6, 100.0] | 50.0 | 5 | 1 |" in sc
    assert "Fisher exact" in sc

    q = pd.read_csv(out / "quality.csv")
    assert len(q) == len(res)
    qmd = (out / "quality.md").read_text()
    assert "| Simple 2D | seen | MPNet (NR) | 1.30 | 1.54 | 3 | 1.20 | 2 |" in qmd
    assert "exact shortest path" in qmd and "2000 iterations" in qmd and "1.0 s" in qmd

    ab = pd.read_csv(out / "ablations.csv")
    assert list(ab["planner"]) == ["mpnet_nr", "mpnet_nr_random", "mpnet_hr", "mpnet_hr_zeros"]
    assert list(ab["base"]) == ["mpnet_nr", "mpnet_nr", "mpnet_hr", "mpnet_hr"]
    assert ab["success_p_vs"].isna().tolist() == [True, False, True, False]  # bases are not compared
    amd = (out / "ablations.md").read_text()
    lo, hi = wilson_by_hand(1, 5)
    assert (
        f"| MPNet (NR): random | a uniformly random valid state instead of Pnet's proposal | "
        f"≈ 20.0 [{100 * lo:.1f}, {100 * hi:.1f}] | 1.00 [1.00, 1.00] | 5.00 [" in amd
    )
    assert (
        "| MPNet (HR): zeros | Pnet given a zero workspace code | ≈ 100.0 [56.6, 100.0] | "
        "≈ 0.500 [0.500, 0.500] | 1.00 [1.00, 1.00] |" in amd
    )

    eq = pd.read_csv(out / "equal_quality.csv")
    assert list(zip(eq["algorithm"], eq["factor"])) == [("bit_star", 1.0), ("bit_star", 1.1)]
    one, x11 = eq.iloc[0], eq.iloc[1]
    assert (one["queries"], one["no_target"], one["targeted"], one["reached"]) == (4, 1, 3, 2)
    assert (one["reach_ci_low"], one["reach_ci_high"]) == pytest.approx(wilson_by_hand(2, 3))
    assert (one["time_to_reach_median_s"], one["censored"], one["time_reached_median_s"]) == (2.0, False, 1.5)
    assert (one["target_time_median_s"], one["time_ratio"]) == (pytest.approx(0.2), pytest.approx(10.0))
    assert (x11["targeted"], x11["reached"], x11["censored"], x11["budget_s"]) == (3, 1, True, 10.0)
    assert math.isinf(x11["time_to_reach_median_s"]) and math.isinf(x11["time_ratio"])
    assert x11["time_reached_median_s"] == 0.5
    emd = (out / "equal_quality.md").read_text()
    assert "| Simple 2D | seen | BIT* | cost ≤ 1 × MPNet (NR)'s | 1 | 3 | 66.7 [20.8, 93.9] | 2.00 [" in emd
    assert "|  |  | BIT* | cost ≤ 1.1 × MPNet (NR)'s | 1 | 3 | 33.3 [6.1, 79.2] | > budget (10.0 s) [" in emd
    assert "| > 50.0 |" in emd
    readme = (out / "README.md").read_text()
    for name in (
        "quality.md",
        "ablations.md",
        "equal_quality.md",
        "Wilson",
        "Fisher",
        f"{BOOT_N} resamples",
        "rigid (Rigid body): path cost = OMPL's SE(2) metric",
    ):
        assert name in readme

    # a later report without those runs removes their tables
    rc, out = report(tmp_path, quality_logs / "bit0")
    assert rc == 0 and not any(
        (out / f"{n}.{e}").exists() for n in ("quality", "ablations", "equal_quality") for e in ("md", "csv")
    )


def test_env_order():
    assert sorted(["zeta", "rigid", "arm7", "s2d", "c3d", "c2d"], key=env_rank) == [
        "s2d",
        "c2d",
        "c3d",
        "rigid",
        "arm7",
        "zeta",
    ]


@pytest.mark.slow  # the whole report, end to end
def test_incomplete_and_unfinished_runs_are_flagged(tmp_path, capsys):
    """A run that logged fewer queries than its test set holds, and a file a kill left
    unfinalised, are named under Warnings with what they hold."""
    logs = tmp_path / "logs"
    part = write_log(logs / "part", "s2d", "bit_star", 0, [Q("seen", "0", 0, True, 1.0)], queries_expected=400)
    full = write_log(logs / "full", "s2d", "bit_star", 1, [Q("seen", "0", 0, True, 1.0)], queries_expected=1)
    cut = logs / "cut" / "trials.mcap"
    cut.parent.mkdir()
    cut.write_bytes(full.read_bytes()[: len(full.read_bytes()) * 2 // 3])
    rc, out = report(tmp_path, logs)
    err = capsys.readouterr().err
    assert rc == 0
    assert f"warning: {part}: incomplete run: 1 of 400 queries logged" in err
    assert f"warning: {cut}: was not finalised" in err and "harness.repair" in err
    assert f"warning: {full}:" not in err
    assert "incomplete run: 1 of 400" in (out / "README.md").read_text()


@pytest.mark.slow  # the whole report, end to end
def test_output_folder_is_never_overwritten_by_accident(tmp_path, capsys):
    """The default output is DIR/report/; a folder the report did not make is refused (one line)
    unless --force; a folder it made is written into again."""
    logs = tmp_path / "logs"
    write_log(logs / "bit", "s2d", "bit_star", 0, [Q("seen", "0", 0, True, 1.0)])
    assert main([str(logs)]) == 0
    assert (logs / "report" / "results.csv").is_file() and (logs / "report" / ".mpnet-report").is_file()
    assert main([str(logs)]) == 0  # its own folder: fine
    capsys.readouterr()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    assert main([str(logs), "--out", str(mine)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "--force" in err
    assert {p.name for p in mine.iterdir()} == {"notes.txt"}
    assert main([str(logs), "--out", str(mine), "--force"]) == 0
    assert (mine / "results.csv").is_file() and (mine / "notes.txt").read_text() == "mine"
    assert main([str(logs), "--out", str(mine)]) == 0  # --force marked it as the report's
    assert "--out" in (mine / "README.md").read_text().splitlines()[2]


@pytest.mark.slow  # the whole report, end to end
def test_labelled_runs_are_not_pooled(tmp_path, capsys):
    """Two labelled folders with the same env, planner and seed are two rows of results.csv, two
    columns of Table I and two series of the figures; unlabelled, they are pooled."""
    a, b = tmp_path / "rev_a", tmp_path / "rev_b"
    write_log(a / "bit", "s2d", "bit_star", 0, [Q("seen", "0", 0, True, 1.0), Q("seen", "0", 1, True, 2.0)])
    write_log(b / "bit", "s2d", "bit_star", 0, [Q("seen", "0", 0, True, 4.0), Q("seen", "0", 1, False, 9.0)])
    out = tmp_path / "out"
    assert main(["--label", f"A={a}", "--label", f"B={b}", "--out", str(out)]) == 0
    assert "more than one file" not in capsys.readouterr().err
    r = pd.read_csv(out / "results.csv").set_index("planner")
    assert list(r.index) == ["bit_star [A]", "bit_star [B]"]
    assert r.loc["bit_star [A]", ["queries", "successes"]].tolist() == [2, 2]
    assert r.loc["bit_star [B]", ["queries", "successes"]].tolist() == [2, 1]
    assert r.loc["bit_star [B]", "time_mean_s"] == pytest.approx(4.0)
    t1 = pd.read_csv(out / "table1.csv").iloc[0]
    assert (t1["bit_star [A]_time_mean_s"], t1["bit_star [B]_time_mean_s"]) == (pytest.approx(1.5), 4.0)
    assert "| BIT* [A] | BIT* [B] |" in (out / "table1.md").read_text()
    assert main(["--label", "nobrackets", "--out", str(out)]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    pooled = tmp_path / "pooled"
    assert main([str(a), str(b), "--out", str(pooled)]) == 0
    assert "s2d bit_star seed 0: 2 queries logged in more than one file" in capsys.readouterr().err
    r = pd.read_csv(pooled / "results.csv")
    assert r["planner"].tolist() == ["bit_star"] and r["queries"].tolist() == [4]


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


def test_a_scale_with_env_specific_sizes_names_its_envs():
    """One scale name with two sizes (arm7's quick is its own): each bullet says whose it is."""
    from harness.report.readme import _scale_rows, scale_bullet

    small, big = (10, 60, 10, 5, 10, 5), (100, 40, 100, 2, 10, 20)
    rows = _scale_rows({("quick", small, True): {"arm7"}, ("quick", big, True): {"rigid", "s2d"}})
    assert [r[3] for r in rows] == ["arm7", "s2d, rigid"]
    assert scale_bullet(*rows[0]).startswith("Our `quick` scale for arm7 trains smaller networks on 10 workspaces")
    assert _scale_rows({("quick", big, True): {"s2d", "c2d"}})[0][3] == ""  # one size: no envs named
    assert scale_bullet(*_scale_rows({("quick", big, True): {"s2d"}})[0]).startswith("Our `quick` scale trains")


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_timed_out_queries_cpu_share_is_reported_and_a_loaded_run_flagged(tmp_path):
    """A timed-out query that got 4.5 s of CPU in a 10 s budget ran on a loaded machine: its
    row says so (timeout_cpu_share 0.45) and the report warns that its rate is a lower bound;
    a run whose timeouts got a whole CPU is not flagged."""
    logs = tmp_path / "logs"
    for planner, cpu in (("bit_star", 4.5), ("rrt_connect", 9.8)):
        write_log(
            logs / planner,
            "s2d",
            planner,
            0,
            [Q("seen", "0", 0, True, 0.1), Q("seen", "0", 1, False, 10.0, stats={"cpu_s": cpu})],
        )
    rc, out = report(tmp_path, logs)
    assert rc == 0
    res = pd.read_csv(out / "results.csv").set_index("planner")
    assert res.loc["bit_star", "timeouts"] == 1 and res.loc["bit_star", "timeout_cpu_share"] == pytest.approx(0.45)
    assert res.loc["rrt_connect", "timeout_cpu_share"] == pytest.approx(0.98)
    warned = [w for w in (out / "README.md").read_text().splitlines() if "of a CPU" in w]
    assert len(warned) == 2 and all("bit_star" in w for w in warned)  # its queries waited; its rate a lower bound
    assert any("lower bound" in w for w in warned) and any("waited for the CPU" in w for w in warned)


@pytest.mark.parametrize(
    ("cpu", "warning"), [(0.05, "waited for the CPU"), (0.15, "more than one thread"), (0.1, None)]
)
@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_a_run_whose_queries_waited_or_ran_two_threads_is_flagged(tmp_path, cpu, warning):
    """cpu_share: the planned queries' CPU time over their wall time. Well under one, they
    waited for a CPU (a loaded machine: their times are not the planner's); over one, a second
    thread ran. Solved queries only, no timeouts: the timeouts' share does not see it."""
    logs = tmp_path / "logs"
    queries = [Q("seen", "0", i, True, 0.1, stats={"cpu_s": cpu}) for i in range(3)]
    write_log(logs / "nr", "s2d", "mpnet_nr", 0, queries)
    rc, out = report(tmp_path, logs)
    assert rc == 0
    res = pd.read_csv(out / "results.csv")
    assert res.loc[0, "cpu_share"] == pytest.approx(cpu / 0.1)
    warned = [w for w in (out / "README.md").read_text().splitlines() if "of a CPU" in w]
    assert [warning in w for w in warned] == ([True] if warning else [])


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


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_a_run_from_a_dirty_tree_is_marked_in_every_table(tmp_path):
    """Uncommitted code made MPNet's run: its label carries the mark in every table, each table
    says what the mark means, and results.csv flags its rows; BIT*'s clean run is unmarked."""
    runs = tmp_path / "runs"
    qs = [Q("seen", "0", 0, True, 1.0, cost=40.0), Q("seen", "0", 1, True, 2.0, cost=45.0)]
    write_log(runs / "bit", "s2d", "bit_star", 0, qs)
    write_log(runs / "nr", "s2d", "mpnet_nr", 0, qs, git_rev="abc1234-dirty")
    out = tmp_path / "out"
    assert main([str(runs), "--out", str(out)]) == 0
    r = pd.read_csv(out / "results.csv").set_index("planner")
    assert r["dirty"].to_dict() == {"bit_star": False, "mpnet_nr": True}
    tables = sorted(p for p in out.glob("*.md") if p.name != "README.md")
    assert {p.name for p in tables} >= {"table1.md", "success_cost.md"}
    for p in tables:
        text = p.read_text()
        assert "MPNet (NR) †" in text and "BIT* †" not in text, p.name
        assert "† Some runs of this planner come from a dirty tree" in text and "abc1234-dirty" in text, p.name
    assert "% † Some runs" in (out / "table1.tex").read_text()
    clean = tmp_path / "clean"
    write_log(clean / "nr", "s2d", "mpnet_nr", 0, qs)
    facts, _ = planner_facts(load([clean])[0])
    assert facts.dirty == {} and facts.label("mpnet_nr") == "MPNet (NR)" and facts.dirty_note() == ""


def test_every_failure_the_harness_logs_has_a_named_status():
    """A failure reason the harness writes maps to a status Planner Arena names (never
    "Unknown status"): a cost-target query with no target is "not run"."""
    import pandas as pd

    from harness.report.arena import OMPL_STATUS, ST_UNKNOWN, ompl_status

    failures = ["timeout", "invalid_query", "error", "no_solution", "recheck_collision", "no_target", None]
    success = [False] * 6 + [True]
    st = ompl_status(pd.Series(success), pd.Series(failures))
    assert ST_UNKNOWN not in st
    assert [OMPL_STATUS[s] for s in st] == [
        "Timeout",
        "Invalid start",
        "Crash",
        "Abort",
        "Invalid solution (failed the re-check)",
        "Not run (no target: the planner it chases failed)",
        "Exact solution",
    ]


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_resumed_log_names_every_revision_that_planned_it(tmp_path):
    """A resumed log's /run is its last session's: the report named that revision and start alone
    for queries three sessions planned (Informed-RRT* on MBM's 700 ran at two revisions). The
    resume now records the earlier sessions, and the README, results.csv's dirty mark and Planner
    Arena read them all."""
    d = tmp_path / "logs" / "bit"
    revs = ["aaa1111", "bbb2222-dirty", "ccc3333"]
    for i, rev in enumerate(revs):
        started = f"2026-11-2{i}T01:00:00+00:00"
        write_log(
            d, "s2d", "bit_star", 0, [Q("seen", "0", i, True, 1.0)], resume=i > 0, git_rev=rev, started_at=started
        )
    (run,) = [m.data for m in read_log(d / "trials.mcap")[0] if m.topic == "/run"]
    assert [s["git_rev"] for s in run_segments(run)] == revs
    assert run["resumed_from"]["queries"] == 2
    rc, out = report(tmp_path, tmp_path / "logs")
    assert rc == 0
    readme = (out / "README.md").read_text()
    assert "- Git revision of the runs: aaa1111, bbb2222-dirty, ccc3333\n" in readme
    assert "between 2026-11-20T01:00:00+00:00 and 2026-11-22T01:00:00+00:00" in readme
    assert pd.read_csv(out / "results.csv")["dirty"].all()
    with sqlite3.connect(out / "benchmark.db") as db:
        setup, date = db.execute("SELECT setup, date FROM experiments").fetchone()
    assert "git aaa1111, bbb2222-dirty, ccc3333" in setup and date == "2026-11-20T01:00:00+00:00"


def test_judge_bullet_says_how_each_env_was_judged():
    """The README said "every 0.01 along the path, exact boxes" for every env, the arm's too
    (judged by pybullet at 0.002 rad): each env now gets its own step, as its runs logged it,
    and its checker's geometry."""
    text = judge_bullet({"panda_mbm": {0.002}, "s2d": {None}, "rigid": {0.01, 0.005}, "mystery": {None}})
    how = text.split("(", 1)[1].rsplit(")", 1)[0]
    assert how.split("; ") == [
        "s2d: every 0.01 along the path, a point against the boxes, exact",
        "rigid: every 0.005 or 0.01 along the path, the rectangle against the boxes, exact (separating axes)",
        "panda_mbm: every 0.002 rad along the path, pybullet on the arm model's collision meshes, no margin",
        "mystery: as its runs' config says",
    ]
    assert "exact boxes" not in judge_bullet({"arm7": {0.002}})


@pytest.mark.slow  # two whole reports
def test_generated_and_file_runs_of_a_planner_are_not_labelled_apart(tmp_path):
    """A planner run on the generated split and on a problem file (the same settings but
    `problems`) keeps its plain name: the two never share a split, so nothing pools them. Before,
    a recipe screen's tables named them `mpnet_nr [problems=null]` and `mpnet_nr [problems=298f2524]`.
    Two problem files are still two variants."""
    logs = tmp_path / "logs"
    settings = {"seed": 0, "budget_s": 10.0, "planner.name": "rrt_connect", "problems": None}
    gen = [Q("seen", "0", i, True, 1.0) for i in range(2)]
    on_file = [Q("file", "0", i, True, 1.0) for i in range(2)]
    write_log(logs / "gen", "s2d", "rrt_connect", 0, gen, settings=settings)
    write_log(logs / "a", "s2d", "rrt_connect", 0, on_file, settings={**settings, "problems": "sha256:" + "a" * 64})
    rc, out = report(tmp_path, logs)
    assert rc == 0
    assert set(pd.read_csv(out / "results.csv")["planner"]) == {"rrt_connect"}
    write_log(logs / "b", "s2d", "rrt_connect", 0, on_file, settings={**settings, "problems": "sha256:" + "b" * 64})
    rc, out = report(tmp_path, logs)
    assert rc == 0
    assert set(pd.read_csv(out / "results.csv")["planner"]) == {
        "rrt_connect",
        "rrt_connect [problems=aaaaaaaa]",
        "rrt_connect [problems=bbbbbbbb]",
    }
