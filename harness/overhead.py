"""`python -m harness.overhead +env=ENV +planner=PLANNER [scale=S]`: what the harness
costs per query beside the planner, from a real bench run with every log written.

Reports, per query, the planner's time (the measured `time_s`) and the planning loop's
own work around it (building the problem, bookkeeping, the progress bar, handing the
query to the log process), as medians and p90s and as fractions of planning time; and
the log process's CPU time per query (the fine re-check and writing MCAP, Rerun and
CSV), which runs beside the loop.
"""

from __future__ import annotations

import statistics
import tempfile
from pathlib import Path

from harness.core.threads import single_threaded

single_threaded()  # before numpy, scipy, torch or numba load (harness.core.threads)

import hydra  # noqa: E402
import numpy as np  # noqa: E402
from omegaconf import DictConfig  # noqa: E402

from harness.core.cli import run_hydra  # noqa: E402


def _row(name: str, xs: list[float], plan: list[float]) -> str:
    a = np.asarray(xs)
    frac = a.sum() / np.sum(plan)
    return (
        f"{name:<22} median {np.median(a) * 1e3:8.3f} ms   p90 {np.percentile(a, 90) * 1e3:8.3f} ms   "
        f"total/planning {frac * 100:6.1f}%"
    )


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    from harness.bench import QueryTiming, bench_or_exit

    timing = QueryTiming()
    with tempfile.TemporaryDirectory() as tmp:
        bench_or_exit(cfg, Path(tmp), timing=timing, quiet=True)
    if not timing.plan_s:
        return
    plan = timing.plan_s
    print(f"\nharness overhead, {cfg.env.name} / {cfg.planner.get('name') or 'planner'}, {len(plan)} queries")
    print(_row("planner (time_s)", plan, plan))
    print(_row("harness in the loop", timing.harness_s, plan))
    if any(timing.diagnostics_s):
        print(_row("diagnostics (untimed)", timing.diagnostics_s, plan))
    print(
        f"{'log process (CPU)':<22} mean   {timing.log_cpu_s / len(plan) * 1e3:8.3f} ms per query "
        f"(re-check and writing, beside the loop)   total/planning {timing.log_cpu_s / sum(plan) * 100:6.1f}%"
    )
    ratio = [h / p for h, p in zip(timing.harness_s, plan) if p > 0]
    print(
        f"per-query harness/planning ratio: median {statistics.median(ratio) * 100:.1f}%, "
        f"p90 {np.percentile(ratio, 90) * 100:.1f}%"
    )


if __name__ == "__main__":
    run_hydra(main, required=("env", "planner"))
