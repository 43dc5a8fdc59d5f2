"""One thread per timed process (harness.core.threads): every pool a run loads, scipy's OpenBLAS that
numba's kernels load after the run started included, at one thread, and recorded in /run."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from harness.core.threads import extra_threads
from tests.harness._cli import read_mcap

PROBE = """
import json, os
import numpy  # a BLAS loaded before: limited where it is
from harness.core.threads import single_threaded, thread_pools
single_threaded()
import scipy.linalg  # scipy's own OpenBLAS, loaded after: reads the variables
print(json.dumps(thread_pools()))
"""


def test_pools_loaded_before_and_after_are_single_threaded():
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    p = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, timeout=120)
    assert p.returncode == 0, p.stderr
    pools = json.loads(p.stdout)
    assert sum(p["library"] == "openblas" for p in pools) >= 2  # numpy's and scipy's copies
    assert extra_threads(pools) == [] and all(p["threads"] == 1 for p in pools)


def test_extra_threads_names_each_pool_over_one():
    pools = [
        {"api": "blas", "library": "openblas", "file": "libscipy_openblas.so", "threads": 2},
        {"api": "numba", "library": "numba", "file": "", "threads": 1},
    ]
    assert extra_threads(pools) == ["openblas (libscipy_openblas.so): 2 threads"]


@pytest.mark.slow
def test_a_run_records_its_pools_each_at_one_thread(tmp_path, run_cli):
    """MPNet's compiled loop loads scipy's OpenBLAS (Pnet's products) at warm-up, before /run:
    the record has it, and every pool at one thread, whatever the machine's cores."""
    out = tmp_path / "run"
    env = {k: "" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}  # the user's own settings do not decide it
    run_cli("harness", "+env=s2d", "+planner=mpnet_nr", "scale=tiny", "rerun=false", f"hydra.run.dir={out}", env=env)
    run = next(m for t, m in read_mcap(out / "trials.mcap")[1] if t == "/run")
    pools = run["threads"]
    assert any(p["library"] == "openblas" and "scipy" in p["file"] for p in pools)
    assert {p["api"] for p in pools} >= {"blas", "numba"} and all(p["threads"] == 1 for p in pools)


def test_each_query_starts_on_a_fresh_time_slice(monkeypatch):
    """plan_query yields the CPU before it starts the clock: on a loaded machine, what the
    harness did since the last query (MPNet's diagnostics, logging) no longer eats into the
    query's slice, which made MPNet wait inside its queries more than BIT* (loaded / quiet
    ratio of their medians 2.2 before, 0.9 after: docs/research/threads_under_load.py at 993d64b)."""
    import numpy as np

    from harness.bench import loop
    from mpnet.envs.scenes.generators import make_workspace
    from mpnet.envs.specs import get_spec
    from mpnet.planners.base import Problem, Result

    events = []

    class Planner:
        name = "probe"

        def solve(self, problem, budget_s):
            events.append("solve")
            return Result(None, "no_solution", {})

    monkeypatch.setattr(loop.os, "sched_yield", lambda: events.append("yield"))
    monkeypatch.setattr(loop.time, "perf_counter", lambda: events.append("clock") or 0.0)
    spec = get_spec("s2d")
    ws = make_workspace(spec, 0, "seen")
    loop.plan_query(Planner(), Problem(spec, ws, spec.make_checker(ws), np.zeros(2), np.ones(2)), 1.0)
    assert events[:3] == ["yield", "clock", "solve"]


def test_training_a_run_does_first_uses_every_core_again():
    """A bench run that trains its networks on first use (single-threaded for its queries)
    trains Enet and Pnet on every core, and is single-threaded again after."""
    import torch

    from harness.artifacts import fit
    from harness.core.threads import training_threads

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        seen = []
        training_threads()(lambda: seen.append(torch.get_num_threads()))()
        assert seen == [len(os.sched_getaffinity(0))] and torch.get_num_threads() == 1
        assert all(hasattr(f, "__wrapped__") for f in (fit.fit_enet, fit.fit_models))  # both fits so wrapped
    finally:
        torch.set_num_threads(before)
