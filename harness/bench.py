"""The bench stage: one planner, one seed, every test query, every trial logged."""
from __future__ import annotations

import datetime as _dt
import math
import os
import platform
import socket
import statistics
import subprocess
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np
from omegaconf import DictConfig, OmegaConf

from mpnet.envs.collision import make_checker
from mpnet.envs.specs import get_spec
from mpnet.envs.workspace import EnvSpec, TestSet
from mpnet.planners.base import Planner, Problem, Result

from harness.cli import UsageError

REPO = Path(__file__).resolve().parent.parent
PACKAGES = ("numpy", "ompl", "python-fcl", "hydra-core", "mcap", "rerun-sdk", "torch", "lightning", "mpnet-bench")


def git_rev() -> str:
    try:
        rev = subprocess.run(["git", "-C", str(REPO), "rev-parse", "HEAD"], capture_output=True, text=True,
                             timeout=5).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=5).stdout.strip()
        return (rev + ("-dirty" if dirty else "")) if rev else "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for pkg in PACKAGES:
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            pass
    return out


def run_info(env: str, planner: str, seed: int, split: str, config_yaml: str) -> dict:
    return {
        "env": env, "planner": planner, "seed": int(seed), "split": split, "config": config_yaml,
        "git_rev": git_rev(), "versions": versions(),
        "host": f"{socket.gethostname()} ({os.cpu_count()} cpus, {platform.machine()})",
        "started_at": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
    }


_OMPL_SEEDED = False


def ompl_seeded() -> bool:
    return _OMPL_SEEDED


def seed_everything(seed: int) -> None:
    """OMPL's RNG once per process, before any planner exists (its seed must be > 0, so
    OMPL gets seed + 1)."""
    global _OMPL_SEEDED
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_WARN)
    if _OMPL_SEEDED:
        raise RuntimeError("OMPL's RNG can be seeded once per process")
    ou.RNG.setSeed(int(seed) + 1)
    _OMPL_SEEDED = True
    np.random.seed(int(seed) % 2**32)
    try:
        import torch  # MPNet's dropout; absent for classical-only installs
    except ImportError:
        return
    torch.manual_seed(int(seed))


@dataclass
class QueryTiming:
    """Where a query's wall time went in the planning loop: the planner, the harness
    (set-up, bookkeeping, the hand-off to the log process); and the log process's CPU
    time for the whole run (judging and writing)."""

    plan_s: list[float] = field(default_factory=list)
    harness_s: list[float] = field(default_factory=list)
    log_cpu_s: float = 0.0


def _jsonable(v):
    if isinstance(v, (np.floating, np.integer, np.bool_)):
        return v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def plan_query(planner: Planner, problem: Problem, budget_s: float) -> dict:
    """Solve one query, timed: the record's fields, `failure` None when the planner claims an
    exact solution in the budget. `success` (the claim and the fine re-check) and the path
    cost are decided later, in the log process (harness.log.judge)."""
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    try:
        res = planner.solve(problem, budget_s)
    except Exception as e:  # one query's exception is a logged failure; the run goes on
        res = Result(None, "error", {"error": f"{type(e).__name__}: {e}"})
    wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
    failure = None if res.solved else res.status
    if failure is None and wall > budget_s:
        failure = "timeout"
    rec = {
        "failure": failure,
        "path": res.path if res.path is not None else [],
        "time_s": wall,
        "cpu_s": cpu,
        **problem.checker.counts(),
        "planner_status": res.status,
    }
    for k, v in res.stats.items():
        rec.setdefault(k, _jsonable(v))
    return rec


def cost_target(target: Planner, problem: Problem, budget_s: float) -> dict:
    """The target planner's result on the query, for the log: its verified path's cost
    (None when it failed) and time."""
    from mpnet.motion import path_cost, verify_path

    rec = plan_query(target, problem, budget_s)
    ok = rec["failure"] is None and verify_path(problem.spec, problem.workspace, rec["path"], problem.start,
                                                problem.goal, problem.spec.validation_step) is None
    cost = path_cost(problem.spec, rec["path"]) if ok else None
    return {"target_planner": target.name, "target_cost": cost if cost else None, "target_time_s": rec["time_s"]}


def run_bench(testset: TestSet, planner: Planner, log, *, budget_s: float, collision: str = "native",
              progress: bool = True, timing: QueryTiming | None = None, target: Planner | None = None) -> None:
    """Plan every query of the test set not already in the log, handing each to the log.

    With a `target` planner (time to equal quality), target plans each query first,
    untimed; its verified path's cost becomes the problem's cost basis for `planner`
    (stop=cost), and a query it fails is logged as failure "no_target" without planning."""
    from threadpoolctl import threadpool_limits
    from tqdm import tqdm

    spec = testset.spec
    by_ws: dict[tuple[str, str], list] = {}
    for q in testset.queries:
        if (q.split, q.id) not in log.done:
            by_ws.setdefault((q.split, q.workspace_id), []).append(q)
    bar = tqdm(total=sum(map(len, by_ws.values())), disable=not progress, desc=f"{spec.name} {planner.name}",
               unit="query", file=sys.stderr, dynamic_ncols=True)
    # A query's matmuls are tiny (batch 1): BLAS threads only contend with the log process
    # and the other jobs (s2d MPNet-NR median 1.3 ms single-threaded, 1.6 ms with two).
    limits = threadpool_limits(1, user_api="blas")
    try:
        for ws in testset.workspaces:
            queries = by_ws.get((ws.split, ws.id), [])
            log.add_workspace(ws)
            if not queries:
                continue
            checker = make_checker(spec, ws, backend=collision)
            for q in queries:
                t0 = time.perf_counter()
                checker.reset_counts()
                problem = Problem(spec, ws, checker, q.start, q.goal, q.reference_cost)
                rec = {"query_id": q.id, "workspace_id": ws.id, "split": q.split,
                       "start": q.start.tolist(), "goal": q.goal.tolist()}
                if target is not None:
                    got = cost_target(target, problem, budget_s)
                    rec.update(got)
                    checker.reset_counts()
                    problem.reference_cost = got["target_cost"]
                if target is None or problem.reference_cost is not None:
                    rec.update(plan_query(planner, problem, budget_s))
                else:
                    rec.update({"failure": "no_target", "path": [], "time_s": 0.0, "cpu_s": 0.0,
                                **checker.counts(), "planner_status": "no_target"})
                if q.reference_cost is not None:
                    rec["reference_cost"] = q.reference_cost
                log.add_query(rec)
                bar.update(1)
                if timing is not None:
                    timing.plan_s.append(rec["time_s"])
                    timing.harness_s.append(time.perf_counter() - t0 - rec["time_s"])
    finally:
        limits.restore_original_limits()
        bar.close()


def summarize(records: list[dict]) -> list[dict]:
    """Per split: queries, success rate, time over successes, mean cost, checks per query."""
    rows = []
    for split in sorted({r["split"] for r in records}):
        rs = [r for r in records if r["split"] == split]
        ok = [r for r in rs if r["success"]]
        times = [r["time_s"] for r in ok]
        costs = [r["path_cost"] for r in ok if r["path_cost"] is not None]
        rows.append({
            "split": split, "queries": len(rs), "success": len(ok) / len(rs),
            "time_mean_s": statistics.fmean(times) if times else math.nan,
            "time_std_s": statistics.pstdev(times) if len(times) > 1 else 0.0 if times else math.nan,
            "time_median_s": statistics.median(times) if times else math.nan,
            "cost_mean": statistics.fmean(costs) if costs else math.nan,
            "checks_per_query": statistics.fmean(r["collision_checks"] for r in rs),
            "failures": dict(Counter(r["failure"] for r in rs if not r["success"]).most_common()),
        })
    return rows


def format_summary(rows: list[dict]) -> str:
    head = f"{'split':<8} {'queries':>7} {'success':>8} {'time mean ± std (ms)':>22} {'median (ms)':>11} " \
           f"{'cost mean':>9} {'checks/query':>12}  failures"
    lines = [head]
    for r in rows:
        ms = f"{r['time_mean_s'] * 1e3:.2f} ± {r['time_std_s'] * 1e3:.2f}"
        lines.append(f"{r['split']:<8} {r['queries']:>7} {r['success'] * 100:>7.1f}% {ms:>22} "
                     f"{r['time_median_s'] * 1e3:>11.2f} {r['cost_mean']:>9.2f} {r['checks_per_query']:>12.1f}  "
                     + ", ".join(f"{k}: {v}" for k, v in r["failures"].items()))
    return "\n".join(lines)


def env_spec(env_cfg) -> EnvSpec:
    """The env's fixed geometry with the config's validation step."""
    from dataclasses import replace

    return replace(get_spec(env_cfg.name), validation_step=float(env_cfg.validation_step))


def check_config(cfg: DictConfig) -> None:
    """The values a user types, checked before any work: UsageError naming the key."""
    from mpnet.envs.collision import BACKENDS

    def number(key, value, positive=True):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                or (positive and value <= 0):
            raise UsageError(f"config key {key}: expected a {'positive ' if positive else ''}finite number, "
                             f"got {value!r}")

    number("budget_s", cfg.budget_s)
    number("env.validation_step", cfg.env.validation_step)
    number("env.solvable_s", cfg.env.solvable_s)
    if isinstance(cfg.seed, bool) or not isinstance(cfg.seed, int) or cfg.seed < 0:
        raise UsageError(f"config key seed: expected an integer >= 0, got {cfg.seed!r}")
    splits = cfg.splits
    if isinstance(splits, str) or not splits or any(s not in ("seen", "unseen") for s in splits):
        raise UsageError(f"config key splits: expected a list from [seen, unseen], e.g. splits=[seen], got "
                         f"{OmegaConf.to_container(splits) if OmegaConf.is_config(splits) else splits!r}")
    if cfg.env.collision not in BACKENDS:
        raise UsageError(f"config key env.collision: expected one of {', '.join(BACKENDS)}, got {cfg.env.collision!r}")
    for key in ("rerun", "resume", "progress"):
        if not isinstance(cfg[key], bool):
            raise UsageError(f"config key {key}: expected true or false, got {cfg[key]!r}")
    planner = cfg.get("planner", {})
    for sub in (planner, planner.get("cost_target") or {}):
        if sub.get("_target_") == "harness.neural.mpnet_planner":
            from harness.neural import check_ablation

            try:
                check_ablation(sub.get("name"), sub.get("proposal", "pnet"), sub.get("encoding", "cloud"),
                               sub.get("dropout", True))
            except ValueError as e:
                raise UsageError(str(e)) from None
    steps = planner.get("steer_steps")
    if steps is not None:
        if not OmegaConf.is_list(steps) or not all(
                x is None or (isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x > 0)
                for x in steps):
            raise UsageError(f"config key planner.steer_steps: expected null or a list of positive steps "
                             f"(null entries: continuous), got {steps!r}")


def build_testset(cfg: DictConfig, spec):
    """The problem file's test set, or the scale's generated splits (from the cache)."""
    from harness.artifacts import ensure_testset
    from mpnet.data.reference import is_exact, reference_costs
    from mpnet.problems import load_problems

    if cfg.problems:
        testset = load_problems(str(cfg.problems), spec)
        if is_exact(spec):  # exact references cost microseconds: fill the ones the file lacks
            reference_costs(spec, testset.workspaces, [q for q in testset.queries if q.reference_cost is None],
                            iterations=0, expert_s=0.0, bit_star_s=0.0)
        return testset, "file"
    return ensure_testset(cfg, bool(cfg.progress)), "+".join(cfg.splits)


def bench(cfg: DictConfig, run_dir: Path, timing: QueryTiming | None = None, quiet: bool = False) -> list[dict]:
    """Run one bench job into run_dir and print its summary."""
    import hydra
    from hydra.errors import InstantiationException

    from harness.log import LogProcess

    if "env" not in cfg or "planner" not in cfg:
        raise UsageError("choose an env and a planner with +env=NAME +planner=NAME")
    check_config(cfg)
    seed_everything(int(cfg.seed))
    spec = env_spec(cfg.env)
    testset, split = build_testset(cfg, spec)
    target_cfg = cfg.planner.get("cost_target")
    extra = {}
    if cfg.planner.get("needs_models") or (target_cfg is not None and target_cfg.get("needs_models")):
        from harness.artifacts import ensure_models

        models_folder, _, _ = ensure_models(cfg, progress=bool(cfg.progress))
        extra = {"models_folder": models_folder, "spec": spec, "points_per_block": int(cfg.env.points_per_block),
                 "data_seed": int(cfg.env.data_seed), "seed": int(cfg.seed)}

    def make(planner_cfg, key: str, models: bool):
        try:
            # Objects (the spec, folders) cannot go through OmegaConf: bind them to a partial.
            factory = hydra.utils.instantiate(
                {k: v for k, v in planner_cfg.items() if k not in ("needs_models", "cost_target")}, _partial_=True)
            return factory(**(extra if models else {}))
        except InstantiationException as e:
            raise UsageError(f"config key {key}: {e.__cause__ or e}") from None

    planner = make(cfg.planner, "planner", bool(cfg.planner.get("needs_models")))
    target = None if target_cfg is None else make(target_cfg, "planner.cost_target",
                                                   bool(target_cfg.get("needs_models")))
    if target is None and cfg.planner.get("stop") == "cost" \
            and any(q.reference_cost is None for q in testset.queries):
        raise UsageError("planner.stop=cost needs a reference cost for every query "
                         "(give `reference_cost` per query in a problem file)")
    info = run_info(cfg.env.name, cfg.planner.name, int(cfg.seed), split, OmegaConf.to_yaml(cfg, resolve=True))
    with LogProcess(run_dir, info, spec, validation_step=spec.validation_step, rerun=bool(cfg.rerun),
                    resume=bool(cfg.resume)) as log:
        for ws in testset.workspaces:
            logged = log.logged_obstacles.get((ws.split, ws.id))
            if logged is not None and logged != ws.obstacles_json():
                raise UsageError(f"resume=true: workspace {ws.id!r} ({ws.split}) in {run_dir} was logged with "
                                 f"other obstacles; resume only the same test set or problem file")
        if log.done:
            print(f"resuming: {len(log.done)} queries already logged in {run_dir}", file=sys.stderr)
        try:
            run_bench(testset, planner, log, budget_s=float(cfg.budget_s), collision=str(cfg.env.collision),
                      progress=bool(cfg.progress), timing=timing, target=target)
        except KeyboardInterrupt:
            log.close()
            print(f"interrupted: every finished query is in {run_dir / 'trials.mcap'}", file=sys.stderr)
            raise
    records = log.records
    if timing is not None:
        timing.log_cpu_s = log.child_cpu_s
    if not quiet:
        print(f"{cfg.env.name} / {cfg.planner.name} / seed {cfg.seed}: {run_dir}")
        print(format_summary(summarize(records)) if records else "no queries to run")
    return records


def bench_or_exit(cfg: DictConfig, run_dir: Path, **kwargs) -> None:
    """bench(), with the user's mistakes as one line and exit status 1."""
    from mpnet.problems import ProblemFileError

    try:
        bench(cfg, run_dir, **kwargs)
    except (ProblemFileError, UsageError) as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(1)
    except FileExistsError as e:
        print(f"error: {e} (or choose another hydra.run.dir)", file=sys.stderr)
        sys.exit(1)


def bench_in_child(container: dict, run_dir: str) -> None:
    bench_or_exit(OmegaConf.create(container), Path(run_dir))
