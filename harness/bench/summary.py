"""The table a bench run prints at its end, per split."""

from __future__ import annotations

import math
import statistics


def summarize(tally) -> list[dict]:
    """Per split of a harness.log.tally.Tally: queries, success rate, time over successes,
    mean cost, checks per query, failures by reason."""
    rows = []
    for split in sorted(tally.splits):
        t = tally.splits[split]
        times, costs = list(t.times), list(t.costs)
        rows.append(
            {
                "split": split,
                "queries": t.queries,
                "success": len(times) / t.queries,
                "time_mean_s": statistics.fmean(times) if times else math.nan,
                "time_std_s": statistics.pstdev(times) if len(times) > 1 else 0.0 if times else math.nan,
                "time_median_s": statistics.median(times) if times else math.nan,
                "cost_mean": statistics.fmean(costs) if costs else math.nan,
                "checks_per_query": t.checks / t.queries,
                "failures": dict(t.failures.most_common()),
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
