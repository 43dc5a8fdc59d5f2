"""The bench stage (`python -m harness`): one planner, one seed, every test query, every
trial logged. `run` assembles a job, `loop` times the queries, `summary` prints."""

from harness.bench.loop import CostTarget, QueryTiming, plan_query, run_bench
from harness.bench.run import bench, bench_in_child, bench_or_exit, preload_jobs, seed_everything
from harness.bench.summary import format_summary, summarize

__all__ = [
    "CostTarget",
    "QueryTiming",
    "plan_query",
    "run_bench",
    "bench",
    "bench_in_child",
    "bench_or_exit",
    "preload_jobs",
    "seed_everything",
    "format_summary",
    "summarize",
]
