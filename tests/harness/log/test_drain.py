"""The log process's inbox read ahead and its backlog judged by two processes (harness.log.drain):
the same records, in the same order, whoever judges them; a helper that dies leaves its share
to the log process; a real arm's paths judged the same by one process and by two."""

from __future__ import annotations

import multiprocessing as mp
import os
import time
from dataclasses import dataclass

import numpy as np
import pytest

from harness.log.drain import JudgeRate, ReadAhead, helper_share, judge_backlog
from harness.log.process import LogProcess


@dataclass(frozen=True)
class Ws:
    id: str
    split: str = "seen"


def fake_judge(spec, ws, rec, step):
    """A judge whose verdict depends on the record alone; it says which process gave it."""
    time.sleep(0.002)
    return {**rec, "success": rec["k"] % 3 != 0, "by": os.getpid()}


def dying_judge(spec, ws, rec, step):
    if os.environ.get("MPNET_BENCH_TEST_PARENT") != str(os.getpid()):
        os._exit(3)  # the helper dies on its first record
    return fake_judge(spec, ws, rec, step)


def rec(k: int, ws: str) -> dict:
    return {"k": k, "split": "seen", "workspace_id": ws, "failure": None, "path": [[0.0, 0.0], [1.0, 0.0]]}


def backlog():
    return [
        ("workspace", Ws("a")),
        ("queries", [rec(k, "a") for k in range(12)]),
        ("workspace", Ws("b")),
        ("queries", [rec(k, "b") for k in range(12, 30)]),
        ("close", None),
    ]


def drained(judge, judges: int, start_s: float):
    written, rate = [], JudgeRate()
    cpu, helped = judge_backlog(
        backlog(), judge, None, {}, rate, 0.01, lambda k, p: written.append((k, p)), judges, start_s
    )
    assert (helped > 0) == (cpu > 0)
    return written, cpu


def test_helper_share_known_answers():
    assert helper_share([1.0] * 10, 1.5) == 4  # (10 - 1.5) / 2 = 4.25 s for it: the last four
    assert helper_share([1.0] * 10, 0.0) == 5
    assert helper_share([10.0], 0.0) == 0 and helper_share([], 0.0) == 0  # one query: nothing to share
    assert helper_share([0.1] * 10, 1.5) == 0  # a backlog shorter than a start


def test_read_ahead_keeps_the_order_and_sees_the_close_or_the_end():
    ours, theirs = mp.Pipe(duplex=False)
    sent = [("workspace", 1), ("queries", [2, 3]), ("close", None)]
    for m in sent:
        theirs.send(m)
    inbox = ReadAhead(ours)
    assert inbox.get() == sent[0]
    deadline = time.time() + 10
    while not inbox.closing and time.time() < deadline:
        time.sleep(0.001)
    assert inbox.rest() == sent[1:]
    ours, theirs = mp.Pipe(duplex=False)
    theirs.send(("queries", [4]))
    theirs.close()  # the bench died
    inbox = ReadAhead(ours)
    assert inbox.get() == ("queries", [4]) and inbox.get() == ("eof", None) and inbox.closing


@pytest.mark.slow  # starts a helper interpreter (~0.7 s)
def test_two_judges_write_what_one_writes_in_the_same_order():
    alone, cpu1 = drained(fake_judge, 1, 0.0)
    two, cpu2 = drained(fake_judge, 2, 0.0)
    strip = [(k, p if k == "workspace" else [{x: v for x, v in r.items() if x != "by"} for r in p]) for k, p in alone]
    assert [
        (k, p if k == "workspace" else [{x: v for x, v in r.items() if x != "by"} for r in p]) for k, p in two
    ] == strip
    assert [k for k, _ in two] == ["workspace", "queries", "workspace", "queries"]
    judged_by = {r["by"] for k, p in two if k == "queries" for r in p}
    assert cpu1 == 0.0 and cpu2 > 0.0 and len(judged_by) == 2  # a helper took the tail
    assert all(r["by"] == os.getpid() for r in two[1][1])  # the head: this process's


@pytest.mark.slow  # starts a helper interpreter
def test_a_helper_that_dies_leaves_its_share_to_the_log_process(monkeypatch):
    import harness.log.drain as drain

    started = []
    start = drain._start_helper
    monkeypatch.setattr(drain, "_start_helper", lambda *a: started.append(start(*a)) or started[-1])
    monkeypatch.setenv("MPNET_BENCH_TEST_PARENT", str(os.getpid()))
    written, rate = [], JudgeRate()
    _, helped = judge_backlog(backlog(), dying_judge, None, {}, rate, 0.01, lambda k, p: written.append((k, p)), 2, 0.0)
    records = [r for k, p in written if k == "queries" for r in p]
    assert [r["k"] for r in records] == list(range(30)) and helped == 0
    assert {r["by"] for r in records} == {os.getpid()}
    assert len(started) == 1 and started[0].returncode == 3  # one started, and it died


@pytest.mark.slow
def test_an_arms_paths_are_judged_the_same_by_one_process_and_by_two(tmp_path, mbm_dir):
    """Panda paths (straight lines between MBM's queries' ends, free and blocked), pybullet's
    judge: a backlog judged with a helper and without gives the same records; and through the
    log process, one judge and two write the same successes, failures and costs."""
    from harness.log.process import judge
    from mpnet.envs.mbm.files import load_mbm
    from mpnet.envs.specs import get_spec
    from tests.harness.log._helpers import make_rec, make_run, read_all

    spec = get_spec("panda_mbm")
    ts = load_mbm(str(mbm_dir), spec)
    split = ts.workspaces[0].split
    recs = [
        make_rec(
            "panda_mbm",
            f"q{i}",
            q.workspace_id,
            split,
            path=np.linspace(q.start, q.goal, 2 + i % 4),
            start=np.asarray(q.start),
            goal=np.asarray(q.goal),
        )  # fmt: skip
        for i, q in enumerate(ts.queries * 4)
    ]
    msgs = [
        *(("workspace", ws) for ws in ts.workspaces),
        ("queries", recs[:10]),
        ("queries", recs[10:]),
        ("close", None),
    ]
    runs = []
    for judges in (1, 2):
        written = []
        _, helped = judge_backlog(msgs, judge, spec, {}, JudgeRate(), spec.validation_step,
                                  lambda k, p, w=written: w.append((k, p)), judges, 0.0)  # fmt: skip
        assert (helped > 0) == (judges == 2)
        runs.append(
            [
                (r["query_id"], r["success"], r["failure"], r["path_cost"])
                for k, p in written
                if k == "queries"
                for r in p
            ]
        )
    assert runs[0] == runs[1] and len(runs[0]) == 24 and 0 < sum(s for _, s, _, _ in runs[0]) < 24
    outcomes = []
    for judges in (1, 2):
        run_dir = tmp_path / f"judges{judges}"
        with LogProcess(run_dir, make_run("panda_mbm"), spec, validation_step=spec.validation_step, rerun=False,
                        judges=judges, helper_start_s=0.0) as log:  # fmt: skip
            for ws in ts.workspaces:
                log.add_workspace(ws)
            for r in recs:
                log.add_query(r)
        _, msgs = read_all(run_dir / "trials.mcap")
        outcomes.append([(m["query_id"], m["success"], m["failure"], m["path_cost"]) for t, m in msgs if t == "/query"])
    assert outcomes[0] == outcomes[1] == runs[0]
