"""harness.log.starting: a child is forked only from a process that runs one thread."""

from __future__ import annotations

import subprocess
import sys

import pytest

SCRIPT = """
import threading, time
from harness.core.threads import single_threaded
single_threaded()  # as every entry point does first: else numpy's OpenBLAS starts its pool's threads
from harness.log import starting
with starting() as ctx:
    print(ctx.get_start_method())
threading.Thread(target=time.sleep, args=(2,), daemon=True).start()
with starting() as ctx:
    print(ctx.get_start_method())
"""


@pytest.mark.slow  # a subprocess
def test_a_process_of_one_thread_forks_and_one_of_two_spawns(repo):
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, check=True, cwd=repo)
    assert out.stdout.split() == ["fork", "spawn"]
