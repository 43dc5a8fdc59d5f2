"""The table a bench run prints at its end, per split."""

from __future__ import annotations

import math
import statistics
from collections import Counter


def summarize(records: list[dict]) -> list[dict]:
    """Per split: queries, success rate, time over successes, mean cost, checks per query."""
    rows = []
    for split in sorted({r["split"] for r in records}):
        rs = [r for r in records if r["split"] == split]
        ok = [r for r in rs if r["success"]]
        times = [r["time_s"] for r in ok]
        costs = [r["path_cost"] for r in ok if r["path_cost"] is not None]
        rows.append(
            {
                "split": split,
                "queries": len(rs),
                "success": len(ok) / len(rs),
                "time_mean_s": statistics.fmean(times) if times else math.nan,
                "time_std_s": statistics.pstdev(times) if len(times) > 1 else 0.0 if times else math.nan,
                "time_median_s": statistics.median(times) if times else math.nan,
                "cost_mean": statistics.fmean(costs) if costs else math.nan,
                "checks_per_query": statistics.fmean(r["collision_checks"] for r in rs),
                "failures": dict(Counter(r["failure"] for r in rs if not r["success"]).most_common()),
            }
        )
    return rows


def format_summary(rows: list[dict]) -> str:
    head = (
        f"{'split':<8} {'queries':>7} {'success':>8} {'time mean ± std (ms)':>22} {'median (ms)':>11} "
        f"{'cost mean':>9} {'checks/query':>12}  failures"
    )
    lines = [head]
    for r in rows:
        ms = f"{r['time_mean_s'] * 1e3:.2f} ± {r['time_std_s'] * 1e3:.2f}"
        lines.append(
            f"{r['split']:<8} {r['queries']:>7} {r['success'] * 100:>7.1f}% {ms:>22} "
            f"{r['time_median_s'] * 1e3:>11.2f} {r['cost_mean']:>9.2f} {r['checks_per_query']:>12.1f}  "
            + ", ".join(f"{k}: {v}" for k, v in r["failures"].items())
        )
    return "\n".join(lines)
