"""`python -m harness +env=ENV +planner=PLANNER [seed=N] [scale=S] [problems=FILE]`: the bench."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from harness.core.threads import single_threaded

single_threaded()  # before numpy, scipy, torch or numba load: each reads its thread count as it loads

import hydra  # noqa: E402
from omegaconf import DictConfig, OmegaConf  # noqa: E402

from harness.core.cli import run_hydra  # noqa: E402


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    from hydra.types import RunMode

    from harness.bench import bench_in_child, bench_or_exit, preload_jobs
    from harness.log.process import one_thread, starting

    hydra_cfg = hydra.core.hydra_config.HydraConfig.get()
    run_dir = Path(hydra_cfg.runtime.output_dir)
    if cfg.problems:
        cfg.problems = hydra.utils.to_absolute_path(str(cfg.problems))
    overrides = list(hydra_cfg.overrides.task)  # logged in /run: the report says how to run it again
    if hydra_cfg.mode != RunMode.MULTIRUN:
        bench_or_exit(cfg, run_dir, overrides=overrides)
        return
    # Each job of a sweep (several may run in one process: Hydra's basic launcher, a joblib
    # worker) runs in a process of its own, forked before this one has planned or loaded a
    # kernel (starting: else a fresh interpreter), so no job sees another's state.
    if one_thread():  # the jobs will be forked (starting): they inherit it
        preload_jobs()
    with starting() as ctx:
        container = OmegaConf.to_container(cfg, resolve=True)
        child = ctx.Process(target=bench_in_child, args=(container, str(run_dir), overrides, os.getpid()))
        child.start()
    child.join()
    if child.exitcode:
        sys.exit(child.exitcode)


if __name__ == "__main__":
    run_hydra(main, required=("env", "planner"))
