"""A bench job: one env, one planner, one seed; its test set, planner, logs and summary."""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

import numpy as np
from omegaconf import DictConfig, OmegaConf

from harness.artifacts.ensure import ensure_models, ensure_testset, training_paths
from harness.bench.loop import CostTarget, QueryTiming, first_problem, run_bench, warm_up
from harness.bench.summary import format_summary, summarize
from harness.core.cli import RunRefused, UsageError, refuse, status_of
from harness.core.kernels import use_kernel_cache
from harness.core.provenance import run_info
from harness.core.settings import RunSettings, settings_of
from harness.core.threads import extra_threads, single_threaded, thread_pools
from harness.log import MCAP_NAME, LogProcess, LogProcessDied, ResumeRefused, Tally
from mpnet.envs.mbm.files import is_mbm, load_mbm
from mpnet.envs.ompl_space import set_ompl_seed
from mpnet.planners.base import sub_seed
from mpnet.planners.reference import reference_costs
from mpnet.problems import ProblemFileError, load_problems
from mpnet.workers import sigterm_when_parent_ends


def seed_everything(seed: int) -> None:
    """Seed OMPL, numpy and torch for what a run does outside its queries (each query
    reseeds from the seed and its id: harness.bench.loop.query_seed). OMPL's seed must fit
    32 bits and be > 0, so it gets one derived from `seed`, which may be any size. Seeding
    again restarts OMPL's seed generator (no flag of the process remembers a first run)."""
    from ompl import util as ou

    set_ompl_seed(sub_seed(seed))
    ou.setLogLevel(ou.LOG_WARN)
    np.random.seed(int(seed) % 2**32)
    # torch only if something imported it (importing it costs a classical run ~1.5 s): planning
    # draws MPNet's dropout from numpy (each query's Generator), never from torch's RNG.
    if "torch" in sys.modules:
        sys.modules["torch"].manual_seed(int(seed) % 2**63)


def runtime_objects(run: RunSettings, used_networks: list | None = None) -> dict:
    """What the app hands a planner's constructor besides its config: the env, the run's
    seed, the trained networks' folder (built on first use; its folder appended to
    used_networks, so that the run knows it planned on them), the workspace cloud and the
    collision backend."""

    def models_dir():
        folder = ensure_models(run, progress=run.progress, planning=True)[0]
        if used_networks is not None:
            used_networks.append(folder)
        return folder

    return {
        "env": run.env.spec,
        "seed": run.seed,
        "collision": run.env.collision,
        "models_dir": models_dir,
        "cloud": run.env.cloud,
    }


def build_testset(run: RunSettings):
    """The problem file's test set, or the scale's generated splits (from the cache)."""
    spec = run.env.spec
    if run.problems:
        path = run.problems
        testset = load_mbm(path, spec, run.problems_per_set) if is_mbm(path) else load_problems(path, spec)
        if spec.exact_reference:  # exact references cost microseconds: fill the ones the file lacks
            reference_costs(
                spec,
                testset.workspaces,
                [q for q in testset.queries if q.reference_cost is None],
                iterations=0,
                expert_s=0.0,
                bit_star_s=0.0,
            )
        return testset, "file"
    return ensure_testset(run, run.progress), "+".join(run.splits)


def bench(
    cfg: DictConfig,
    run_dir: Path,
    timing: QueryTiming | None = None,
    quiet: bool = False,
    overrides: list[str] | None = None,
) -> Tally:
    """Run one bench job into run_dir and print its summary (of the queries planned now).
    overrides: the job's command-line overrides, logged in /run (the report's commands)."""
    if "env" not in cfg or "planner" not in cfg:
        raise UsageError("choose an env and a planner with +env=NAME +planner=NAME")
    run = settings_of(cfg)
    use_kernel_cache(run.cache_dir)  # before the first kernel runs (harness.core.kernels)
    seed_everything(run.seed)
    spec = run.env.spec
    used_networks = []
    runtime = runtime_objects(run, used_networks)
    planner = run.planner.make(runtime)
    target = run.planner.cost_target
    pre_query = None if target is None else CostTarget(target.make(runtime))
    testset, split = build_testset(run)
    if pre_query is None and run.planner.stop == "cost" and any(q.reference_cost is None for q in testset.queries):
        raise RunRefused(
            "planner.stop=cost needs a reference cost for every query "
            "(give `reference_cost` per query in a problem file)"
        )
    single_threaded()  # already so from the entry point; here for a caller in its own process
    if (problem := first_problem(testset, run.env.collision)) is not None:
        warm_up(planner, problem)  # every library the queries use is loaded now: its pool is recorded
    pools = thread_pools()
    if extra := extra_threads(pools):
        raise RunRefused(f"a timed run needs one thread per pool, and {'; '.join(extra)} (harness.core.threads)")
    name = run.planner.label(planner)
    info = run_info(run.env.name, name, run.seed, split, run.config_yaml)
    info["threads"] = pools
    info["settings"] = run.results
    info["facts"] = {**run.facts, "training_paths_built": training_paths(run) if used_networks else None}
    info["queries_expected"] = len(testset.queries)
    if overrides is not None:
        info["overrides"] = [str(o) for o in overrides]
    log_process = LogProcess(  # `jobs` judge the log's backlog once planning is done (harness.log.drain)
        run_dir, info, spec, validation_step=spec.validation_step, rerun=run.rerun, resume=run.resume, judges=run.jobs
    )
    with log_process as log:
        for ws in testset.workspaces:
            logged = log.logged_obstacles.get((ws.split, ws.id))
            if logged is not None and logged != ws.obstacles_json():
                raise RunRefused(
                    f"resume=true: workspace {ws.id!r} ({ws.split}) in {run_dir} was logged with "
                    f"other obstacles; resume only the same test set or problem file"
                )
        for note in log.notes:
            print(f"resume: {note}", file=sys.stderr)
        if log.done:
            print(f"resuming: {len(log.done)} queries already logged in {run_dir}", file=sys.stderr)
        try:
            run_bench(
                testset,
                planner,
                log,
                budget_s=run.budget_s,
                seed=run.seed,
                collision=run.env.collision,
                progress=run.progress,
                timing=timing,
                pre_query=pre_query,
            )
        except KeyboardInterrupt:
            log.close()
            print(f"interrupted: every finished query is in {run_dir / 'trials.mcap'}", file=sys.stderr)
            raise
    tally = log.tally
    if timing is not None:
        timing.log_cpu_s = log.child_cpu_s
        timing.log_peak_rss_mb = log.child_peak_rss_mb
    if not quiet:
        print(f"{run.env.name} / {name} / seed {run.seed}: {run_dir}")
        print(format_summary(summarize(tally)) if len(tally) else "no queries to run")
    return tally


def bench_or_exit(cfg: DictConfig, run_dir: Path, **kwargs) -> None:
    """bench(), with the user's mistakes and a refused or failed run as one line and its exit
    status (harness.core.cli.refuse: 2 for a mistake in the command, 1 for the others)."""
    try:
        bench(cfg, run_dir, **kwargs)
    except (ProblemFileError, UsageError, ResumeRefused) as e:
        refuse(e, status_of(e), run_dir)
    except FileExistsError as e:
        refuse(f"{e} (or choose another hydra.run.dir)", 1, run_dir)
    except LogProcessDied as e:
        refuse(
            f"{e}: every query it received is in {run_dir / MCAP_NAME}; "
            f"run the same command with resume=true to finish the run",
            1,
            run_dir,
        )


def preload_jobs() -> None:
    """What every job of a sweep would load for itself, loaded once before they are forked
    (harness.__main__): the kernels' source stamps (mpnet.jit.warm_stamps), scipy.linalg (numba
    imports it as it loads a kernel: its BLAS check) and numba's own tables of what it can type
    and lower (filled at the first kernel a process loads): ~0.9 of a job's ~1.5 s before it
    plans. None of it is a job's state, and none starts a thread (the pools are one thread:
    harness.core.threads), so the jobs are still forked."""
    import scipy.linalg  # noqa: F401
    from numba.core.registry import cpu_target

    from mpnet.jit import warm_stamps

    warm_stamps()
    cpu_target.typing_context.refresh()
    cpu_target.target_context.refresh()


def bench_in_child(container: dict, run_dir: str, overrides: list[str] | None = None, parent: int | None = None):
    """A sweep's job in its own process (harness.__main__: forked or spawned). It stops as at a Ctrl-C (every
    finished query kept, exit 130) on SIGTERM and when the sweep's process ends: a sweep killed
    by a scheduler or `kill` otherwise left its job planning on, unseen, beside the runs after it
    (a killed sweep's BIT* job took a core for 30 minutes while the next sweep's runs were timed)."""
    _stop_with_parent(parent)
    try:
        bench_or_exit(OmegaConf.create(container), Path(run_dir), overrides=overrides)
    except KeyboardInterrupt as e:
        print(f"interrupted: {e}" if str(e) else "interrupted", file=sys.stderr)
        sys.exit(130)


def _stop_with_parent(parent: int | None) -> None:
    """SIGTERM as a KeyboardInterrupt (the bench's clean stop), and on Linux a SIGTERM from the
    kernel when the parent ends, however it ends (prctl PR_SET_PDEATHSIG; no library wraps it)."""

    def interrupt(signum, frame):
        raise KeyboardInterrupt(f"signal {signal.Signals(signum).name}")

    signal.signal(signal.SIGTERM, interrupt)
    sigterm_when_parent_ends()
    if parent is not None and os.getppid() != parent:  # it ended before prctl took effect
        raise KeyboardInterrupt("the sweep's process ended")
