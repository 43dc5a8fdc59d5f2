"""A pool's workers end with the process that started them: a `harness.recheck` (or a data
build) stopped by SIGTERM left its workers running their tasks on, unseen, beside the runs timed
after it."""

from __future__ import annotations

import ast
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from mpnet.workers import process_pool
from tests.conftest import REPO_ROOT as REPO
from tests.harness.bench.test_sweep_stop import alive

PARENT = """
import os, sys, time
from mpnet.workers import process_pool

def sleeper(path):
    with open(path + ".tmp", "w") as f:
        f.write(str(os.getpid()))
    os.replace(path + ".tmp", path)
    time.sleep(120)

if __name__ == "__main__":
    with process_pool(1) as pool:
        pool.submit(sleeper, sys.argv[1]).result()
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the parent-death signal is Linux's")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["term", "kill"])
def test_a_pools_workers_end_with_a_killed_parent(tmp_path, sig):
    script = tmp_path / "parent.py"
    script.write_text(textwrap.dedent(PARENT))
    pidfile = tmp_path / "worker.pid"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    parent = subprocess.Popen([sys.executable, str(script), str(pidfile)], env=env)
    deadline = time.monotonic() + 60
    while not pidfile.exists():
        assert parent.poll() is None and time.monotonic() < deadline, "the worker never started"
        time.sleep(0.05)
    worker = int(pidfile.read_text())
    os.kill(parent.pid, sig)
    parent.wait(timeout=30)
    deadline = time.monotonic() + 10  # without the fix it sleeps its 120 s
    while alive(worker) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = alive(worker)
    if left:  # the test leaves no orphan of its own behind
        os.kill(worker, signal.SIGKILL)
    assert not left, "the worker ran on after its parent was killed"


def test_a_pool_works():
    with process_pool(2) as pool:
        assert list(pool.map(abs, [-1, 2, -3])) == [1, 2, 3]


def test_every_pool_is_one_that_ends_with_its_parent():
    """ProcessPoolExecutor is made in mpnet.workers only."""
    made = []
    for path in [*REPO.joinpath("mpnet").rglob("*.py"), *REPO.joinpath("harness").rglob("*.py")]:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None)) == (
                "ProcessPoolExecutor"
            ):
                made.append(str(path.relative_to(REPO)))
    assert made == ["mpnet/workers.py"]
