"""A killed sweep takes its job with it: each job of `python -m harness -m ...` plans in its own
interpreter, which stops (every finished query kept in its log) when the sweep's process gets
SIGTERM or is killed outright, instead of planning on, unseen, beside the runs after it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the parent-death signal is Linux's"),
]

BUDGET = 3  # s per query of the job killed (Informed-RRT* plans to its budget: planner.stop=time)


def _children(pid: int) -> list[int]:
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout
    return [int(x) for x in out.split()]


def alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["term", "kill"])
def test_a_killed_sweep_stops_its_job_and_keeps_its_finished_queries(tmp_path, workdir, sweeps_cache, sig):
    sweep = tmp_path / "sweep"
    cmd = [
        sys.executable, "-m", "harness", "-m", "+env=s2d", "+planner=informed_rrt_star", "planner.stop=time",
        f"budget_s=0.2,{BUDGET}", "seed=0", "scale=tiny", f"cache_dir={sweeps_cache}", f"hydra.sweep.dir={sweep}",
        "hydra.sweep.subdir=job${hydra.job.num}", "progress=false", "rerun=false",
    ]  # fmt: skip
    # Its output to a file, as a scheduler's (or `> log 2>&1`): the orphan was seen so, not with a pipe.
    err = tmp_path / "sweep.err"
    with err.open("w") as log:
        sweep_proc = subprocess.Popen(cmd, cwd=workdir, stdout=log, stderr=subprocess.STDOUT)
    # Killed in the second job (the first plans its 8 queries at 0.2 s each): a kill during the
    # first was seen to stop it, one during a later job not. The second's 8 queries take BUDGET s
    # each, so without the fix its job still plans when the wait below ends (7 x 3 s > 3 + 5 s).
    queries = sweep / "job1" / "queries.csv"
    deadline = time.monotonic() + 300
    while not (queries.exists() and len(queries.read_text().splitlines()) >= 2):  # a header and one query
        assert sweep_proc.poll() is None, err.read_text()
        assert time.monotonic() < deadline, "the second job finished no query in 300 s"
        time.sleep(0.2)
    jobs = _children(sweep_proc.pid)
    assert jobs
    os.kill(sweep_proc.pid, sig)
    sweep_proc.wait(timeout=30)
    deadline = time.monotonic() + BUDGET + 5  # the query in flight ends within its budget
    while any(map(alive, jobs)) and time.monotonic() < deadline:
        time.sleep(0.2)
    left = [j for j in jobs if alive(j)]
    for j in left:  # the test leaves no orphan of its own behind
        os.kill(j, signal.SIGKILL)
    assert not left, "the job plans on after its sweep was killed"
    with open(queries.with_name("trials.mcap"), "rb") as f:
        kept = [m for _, ch, m in make_reader(f).iter_messages() if ch.topic == "/query"]
    assert len(kept) >= 1  # the finished queries are in the log, which reads to its end
