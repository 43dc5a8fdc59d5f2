"""A run's results depend on its config alone: the same seed plans the same paths with a cold
or a warm cache, and a run killed outright then resumed plans what an uninterrupted run does."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from harness.log import read_log
from mpnet.planners.base import sub_seed
from tests.harness.log.test_log_recovery import stock_queries

pytestmark = pytest.mark.slow  # every test here runs the CLI in a subprocess


def paths(run_dir):
    msgs, _ = read_log(run_dir / "trials.mcap", ["/query"])
    out = {(m.data["split"], m.data["query_id"]): m.data["path"] for m in msgs}
    assert len(out) == len(msgs), "a query logged twice"
    return out


def test_sub_seed_takes_any_seed_and_stays_in_ompls_range():
    for seed in (0, 1, 2**31, 2**64 - 1, 10**20):
        s = sub_seed(seed, 7)
        assert 1 <= s <= 2**31 - 1 and s == sub_seed(seed, 7)
    assert sub_seed(0, 1) != sub_seed(0, 2) and sub_seed(0, 1) != sub_seed(1, 1)


def test_cold_and_warm_cache_plan_the_same_paths(tmp_path, run_cli):
    """Building the test set in-process draws from OMPL's RNG; each query reseeds from the run's
    seed and its id, so what ran before does not matter."""
    args = ["harness", "+env=s2d", "+planner=bit_star", "scale=tiny", "rerun=false", f"cache_dir={tmp_path / 'c'}"]
    run_cli(*args, f"hydra.run.dir={tmp_path / 'cold'}")
    run_cli(*args, f"hydra.run.dir={tmp_path / 'warm'}")
    cold, warm = paths(tmp_path / "cold"), paths(tmp_path / "warm")
    assert len(cold) == 8 and cold == warm
    run_cli(*args, "seed=1", f"hydra.run.dir={tmp_path / 'seed1'}")
    assert paths(tmp_path / "seed1") != cold  # the seed does change them
    # harness.report.unchanged says so: every query compared, 0 differ; another seed differs (exit 1)
    run_cli("harness.report.unchanged", str(tmp_path / "cold"), str(tmp_path / "warm"), "--out", str(tmp_path / "u"))
    assert "| s2d | bit_star | 8 / 8 | 8 | 8 | 8 |" in (tmp_path / "u" / "README.md").read_text()
    other = run_cli("harness.report.unchanged", str(tmp_path / "cold"), str(tmp_path / "seed1"), check=False)
    assert other.returncode == 1 and "Compared queries that differ: 0." not in other.stdout


@pytest.mark.parametrize("seed", [2**64 - 1, 10**20])
def test_seeds_of_any_size_run(tmp_path, seed, run_cli):
    run_cli(
        "harness", "+env=s2d", "+planner=rrt_connect", "scale=tiny", "rerun=false", f"seed={seed}",
        f"hydra.run.dir={tmp_path}",
    )  # fmt: skip
    assert len(paths(tmp_path)) == 8


# rigid's quick seen split cut to 5 workspaces: 50 queries, a test set built in seconds and
# shared by the two tests below (sweeps_cache)
KILLED = [
    "harness", "+env=rigid", "+planner=rrt_star", "scale=quick", "splits=[seen]", "scale.test.seen.workspaces=5",
    "progress=false", "rerun=false", "env.reference.bit_star_s=0.01", "env.expert.iterations=10",
]  # fmt: skip
QUERIES = 50
# the same planned with short edges (~50 ms a query, not ~1 ms): a kill after the log's first
# batch lands while the bench still plans (the log reads ahead: the bench no longer waits on it)
LONGER = [*KILLED, "planner.range=0.3"]


def test_kill_9_of_the_process_group_then_resume_equals_an_uninterrupted_run(tmp_path, run_cli, workdir, sweeps_cache):
    """kill -9 of the whole group (the log process too): the file holds what was flushed; the
    same command with resume=true logs every query exactly once, each planned as an
    uninterrupted run plans it, and leaves a file the stock `mcap` reader opens."""
    args = [*KILLED, f"cache_dir={sweeps_cache}"]
    run_cli(*args, f"hydra.run.dir={tmp_path / 'whole'}")
    killed = tmp_path / "killed"
    proc = subprocess.Popen(
        [sys.executable, "-m", *args, f"hydra.run.dir={killed}"],
        cwd=workdir,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    csv_file, deadline = killed / "queries.csv", time.time() + 120
    while time.time() < deadline and not (csv_file.exists() and len(csv_file.read_text().splitlines()) > 10):
        time.sleep(0.005)
    # the CSV gets a batch's lines as they are judged, the MCAP its chunk when the batch ends
    while time.time() < deadline and not read_log(killed / "trials.mcap", ["/query"])[0]:
        time.sleep(0.005)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    first = paths(killed)
    assert 0 < len(first) < QUERIES
    p = run_cli(*args, "resume=true", f"hydra.run.dir={killed}")
    assert f"resuming: {len(first)} queries already logged" in p.stderr
    whole, resumed = paths(tmp_path / "whole"), paths(killed)
    assert len(whole) == len(resumed) == QUERIES
    assert resumed == whole
    assert sorted(stock_queries(killed / "trials.mcap")) == sorted(q for _, q in whole)


def _log_child(pid: int) -> int:
    """The trial-log process among pid's children (forked or spawned; not multiprocessing's
    resource tracker)."""
    for _ in range(500):
        for child in subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split():
            cmd = open(f"/proc/{child}/cmdline", "rb").read().replace(b"\0", b" ")
            if b"resource_tracker" not in cmd:
                return int(child)
        time.sleep(0.01)
    raise AssertionError("no trial-log process")


def test_a_killed_log_process_is_one_line_and_resume_finishes(tmp_path, run_cli, workdir, sweeps_cache):
    args = [*KILLED, f"cache_dir={sweeps_cache}", f"hydra.run.dir={tmp_path / 'run'}"]
    proc = subprocess.Popen([sys.executable, "-m", *args], cwd=workdir, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    csv_file, deadline = tmp_path / "run" / "queries.csv", time.time() + 120
    while time.time() < deadline and not (csv_file.exists() and len(csv_file.read_text().splitlines()) > 5):
        time.sleep(0.005)
    os.kill(_log_child(proc.pid), signal.SIGKILL)
    _, err = proc.communicate(timeout=120)
    err = err.decode()
    assert proc.returncode == 1 and "Traceback" not in err, err
    assert err.strip().splitlines()[-1].startswith("error: the trial-log process died (exit code -9)")
    assert "resume=true" in err
    run_cli(*args, "resume=true")
    assert len(paths(tmp_path / "run")) == QUERIES


def test_a_forked_log_outlives_its_bench_and_finishes_the_file(tmp_path, workdir, sweeps_cache):
    """The bench (one thread) forks its log process, which must not keep the bench's ends of
    their pipes: with them it never saw the bench die (kill -9 of the bench alone) and waited on
    forever; without them it finalises what it received into a file the stock reader indexes."""
    run = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", *LONGER, f"cache_dir={sweeps_cache}", f"hydra.run.dir={run}"],
        cwd=workdir,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    csv_file, deadline = run / "queries.csv", time.time() + 120
    while time.time() < deadline and not (csv_file.exists() and len(csv_file.read_text().splitlines()) > 5):
        time.sleep(0.005)
    log = _log_child(proc.pid)
    assert b"multiprocessing" not in open(f"/proc/{log}/cmdline", "rb").read()  # forked, not spawned
    proc.kill()
    proc.wait()
    for _ in range(1000):
        if not os.path.exists(f"/proc/{log}") or open(f"/proc/{log}/stat").read().split()[2] == "Z":
            break
        time.sleep(0.01)
    else:
        os.kill(log, signal.SIGKILL)
        raise AssertionError("the log process did not see its bench die")
    assert 0 < len(stock_queries(run / "trials.mcap")) < QUERIES
