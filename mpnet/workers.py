"""Processes that end with the process that started them: pool workers, and a sweep's jobs
(harness.bench.run).

A pool's workers outlive a parent stopped by SIGTERM (a scheduler, `kill`): each runs its task
on, unseen, taking a core from whatever is timed next (a killed `harness.recheck` left its two
workers re-checking arm logs for minutes). Each worker here asks the kernel for SIGTERM when its
parent ends (Linux's prctl PR_SET_PDEATHSIG; no library wraps it), however the parent ends.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import sys
from concurrent.futures import ProcessPoolExecutor

PR_SET_PDEATHSIG = 1


def sigterm_when_parent_ends() -> None:
    """This process gets SIGTERM from the kernel when its parent ends (Linux; elsewhere nothing)."""
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def end_with_parent(parent: int) -> None:
    """A worker's initializer: SIGTERM (the default action: exit) when `parent` ends."""
    sigterm_when_parent_ends()
    if os.getppid() != parent:  # it ended before prctl took effect
        os._exit(0)


def process_pool(jobs: int, **kwargs) -> ProcessPoolExecutor:
    """At most `jobs` fresh (spawned: each builds its own OMPL RNG and collision world) worker
    processes that end with this one; kwargs as ProcessPoolExecutor's (max_tasks_per_child)."""
    return ProcessPoolExecutor(
        max_workers=max(1, jobs),
        mp_context=mp.get_context("spawn"),
        initializer=end_with_parent,
        initargs=(os.getpid(),),
        **kwargs,
    )
