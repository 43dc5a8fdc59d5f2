"""One thread per timed process, for every thread pool it loads, and a record of the pools.

Why: a query's work is batch-one (Pnet's matmuls, one collision check at a time); a second
thread in a BLAS or OpenMP pool only contends with the log process and the other jobs. On two
cores with four CPU-burning processes beside it, s2d MPNet-NR's encoding took 10.9 ms (median)
with scipy's OpenBLAS at two threads, 0.24 ms at one. A pool limited after it loaded is not
enough: numba's kernels load scipy's own OpenBLAS later, which reads OPENBLAS_NUM_THREADS when
it loads. So every entry point that times something calls `single_threaded()` before numpy,
scipy, torch or numba load; child processes (a sweep's jobs, the log process; forked or spawned) inherit it.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

# Read by each library as it loads: OpenMP runtimes (libgomp, libiomp: torch, sklearn), the
# BLAS builds numpy and scipy ship (OpenBLAS), MKL, BLIS, Accelerate, numexpr, numba's pool.
THREAD_VARS = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "NUMBA_NUM_THREADS",
)


def single_threaded() -> None:
    """Every thread pool of this process (and of those it starts) at one thread: the
    variables set for libraries not yet loaded; the pools of those already loaded limited."""
    os.environ.update(dict.fromkeys(THREAD_VARS, "1"))
    from tqdm import tqdm

    # no monitor thread (it retunes a slow bar's refresh): left running after a data build, it
    # kept the bench from forking its log process (harness.log.process.starting)
    tqdm.monitor_interval = 0
    if any(m in sys.modules for m in ("numpy", "scipy", "torch", "sklearn")):
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)  # for the rest of the process: not restored
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(1)


def thread_pools() -> list[dict]:
    """The thread pools loaded now: each native library's (threadpoolctl: its API, library,
    file and threads), torch's intra-op pool if torch is loaded, and numba's configured size
    (read without launching its pool)."""
    from threadpoolctl import threadpool_info

    pools = [
        {
            "api": p.get("user_api"),
            "library": p.get("internal_api"),
            "file": Path(p.get("filepath", "")).name,
            "threads": int(p.get("num_threads", 0)),
        }
        for p in threadpool_info()
    ]
    if "torch" in sys.modules:
        pools.append(
            {"api": "torch", "library": "torch", "file": "", "threads": sys.modules["torch"].get_num_threads()}
        )
    if "numba" in sys.modules:
        threads = int(sys.modules["numba"].config.NUMBA_NUM_THREADS)
        pools.append({"api": "numba", "library": "numba", "file": "", "threads": threads})
    return sorted(pools, key=lambda p: (p["api"] or "", p["library"] or "", p["file"]))


def extra_threads(pools: list[dict]) -> list[str]:
    """The pools with more than one thread, as 'library (file): N threads'."""
    return [f"{p['library']} ({p['file'] or p['api']}): {p['threads']} threads" for p in pools if p["threads"] > 1]


@contextmanager
def training_threads() -> Iterator[None]:
    """torch at one thread per core for the untimed training a run may do first (its networks
    built on first use), back to what it was after: single_threaded would halve it on two cores."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(len(os.sched_getaffinity(0)))
    try:
        yield
    finally:
        torch.set_num_threads(before)
