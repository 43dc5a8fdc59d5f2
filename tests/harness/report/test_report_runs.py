"""The runs the report reads (`python -m harness.report`): bad files skipped, runs without
queries or an integer seed, labelled runs kept apart, the output folder never overwritten, and
the runs it flags (incomplete, loaded, waited, from a dirty tree, resumed across revisions)."""

from __future__ import annotations

import os
import sqlite3
import subprocess
import sys

import pandas as pd
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from harness.log import read_log, run_segments
from harness.report.__main__ import main
from harness.report.facts import planner_facts
from harness.report.load import load
from tests.harness.report._helpers import Q, report, write_log


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
