"""Every planner on the same queries, one bench run at a time, each in a fresh process
(OMPL seeds its RNG once per process): times, checks and MPNet's time split read back
from the run's trials.mcap, the harness's own overhead from the timed loop, and each run's
peak memory."""

from __future__ import annotations

import multiprocessing as mp
import tempfile
from pathlib import Path

import numpy as np

from mpnet.planners.neural import SPLIT_KEYS


def compose_run(overrides: list[str]):
    """The config `python -m harness` composes from these overrides (in a spawned child)."""
    from hydra import compose, initialize_config_dir

    with initialize_config_dir(str(Path(__file__).resolve().parents[2] / "conf"), version_base="1.3"):
        return compose("config", overrides)


def _child(overrides: list[str], conn) -> None:
    """One bench run, composed as `python -m harness` would compose it; sends back the
    timing, the logged queries and the peak memory, or the error as one line."""
    from harness.bench import QueryTiming, bench
    from harness.core.provenance import peak_rss_mb
    from harness.report.load import read_trials

    try:
        cfg = compose_run(overrides)
        timing = QueryTiming()
        with tempfile.TemporaryDirectory() as tmp:
            bench(cfg, Path(tmp) / "run", timing=timing, quiet=True)
            tf, _ = read_trials(Path(tmp) / "run" / "trials.mcap")
        queries = tf.queries if tf is not None else []
        conn.send(
            {
                "queries": queries,
                "harness_s": timing.harness_s,
                "plan_s": timing.plan_s,
                "log_cpu_s": timing.log_cpu_s,
                "rss_planning_mb": peak_rss_mb(),
                "rss_log_mb": timing.log_peak_rss_mb,
            }
        )
    except BaseException as e:  # noqa: BLE001 - reported by the parent as one line
        conn.send({"error": f"{type(e).__name__}: {e}"})
    finally:
        conn.close()


def run_one(overrides: list[str], child=_child) -> dict:
    """A bench run (or another measurement, `child(overrides, conn)`) in a spawned process (a
    fresh OMPL RNG, a clean peak-memory count)."""
    ctx = mp.get_context("spawn")
    recv, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=child, args=(overrides, send))
    proc.start()
    send.close()
    try:
        out = recv.recv()
    except EOFError:
        out = {"error": f"the bench process died (exit code {proc.exitcode})"}
    proc.join()
    return out


def _med(xs) -> float:
    xs = [x for x in xs if x is not None and np.isfinite(x)]
    return float(np.median(xs)) if xs else float("nan")


def _p90(xs) -> float:
    xs = [x for x in xs if x is not None and np.isfinite(x)]
    return float(np.percentile(xs, 90)) if xs else float("nan")


def summarize(env: str, planner: str, out: dict) -> dict:
    """One row: success, time_s and plan_s (median and p90 over the solved queries), checks
    per query, MPNet's time split (mean seconds per query, every query), the harness's
    overhead per query as a share of its planning time, and peak memory."""
    qs = out["queries"]
    solved = [q for q in qs if q.get("success")]
    row = {
        "section": "planners",
        "env": env,
        "planner": planner,
        "queries": len(qs),
        "success_rate": len(solved) / len(qs) if qs else float("nan"),
        "time_median_s": _med([q.get("time_s") for q in solved]),
        "time_p90_s": _p90([q.get("time_s") for q in solved]),
        "plan_median_s": _med([q.get("plan_s", q.get("time_s")) for q in solved]),
        "plan_p90_s": _p90([q.get("plan_s", q.get("time_s")) for q in solved]),
        "checks_median": _med([q.get("collision_checks") for q in qs]),
        "state_checks_median": _med([q.get("state_checks") for q in qs]),
        "motion_checks_median": _med([q.get("motion_checks") for q in qs]),
        "configurations_median": _med([q.get("configurations_checked") for q in qs]),
    }
    time_total = sum(float(q.get("time_s") or 0.0) for q in qs)
    cpu_total = sum(float(q.get("cpu_s") or 0.0) for q in qs)
    row["cpu_share"] = cpu_total / time_total if time_total > 0 else float("nan")  # < 0.9: the queries waited
    for k in SPLIT_KEYS:
        vals = [q.get(k) for q in qs if q.get(k) is not None]
        row[f"{k}_share"] = sum(vals) / time_total if vals and time_total > 0 else float("nan")
    ratio = [h / p for h, p in zip(out["harness_s"], out["plan_s"]) if p > 0]
    row["overhead_median"] = _med(ratio)
    row["overhead_p90"] = _p90(ratio)
    row["log_cpu_per_query_s"] = out["log_cpu_s"] / len(qs) if qs else float("nan")
    row["rss_planning_mb"] = out["rss_planning_mb"]
    row["rss_log_mb"] = out["rss_log_mb"]
    return row


def planners(envs: list[str], planner_names: list[str], common: list[str]) -> tuple[list[dict], list[str]]:
    """Rows for every env x planner (in that order), and one line per run that failed."""
    rows, errors = [], []
    for env in envs:
        for p in planner_names:
            out = run_one([f"+env={env}", f"+planner={p}", *common])
            if "error" in out:
                errors.append(f"{env} / {p}: {out['error']}")
                continue
            rows.append(summarize(env, p, out))
    return rows, errors
