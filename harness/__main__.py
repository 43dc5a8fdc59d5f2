"""`python -m harness +env=ENV +planner=PLANNER [seed=N] [scale=S] [problems=FILE]`: the bench."""
from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

from hydra.errors import InstantiationException

from harness.cli import UsageError, run_hydra


def build_testset(cfg: DictConfig, spec):
    """The problem file's test set, or the generated splits of the scale."""
    from mpnet.data.queries import make_testset
    from mpnet.problems import load_problems

    if cfg.problems:
        return load_problems(hydra.utils.to_absolute_path(str(cfg.problems)), spec), "file"
    splits = {s: (int(cfg.scale.test[s].workspaces), int(cfg.scale.test[s].queries)) for s in cfg.splits}
    return make_testset(spec, splits, int(cfg.env.data_seed), float(cfg.env.solvable_s)), "+".join(cfg.splits)


def bench(cfg: DictConfig, timing=None) -> list[dict]:
    from harness.bench import env_spec, format_summary, run_bench, run_info, seed_everything, summarize
    from harness.trial_log import TrialLog

    if "env" not in cfg or "planner" not in cfg:
        raise UsageError("choose an env and a planner with +env=NAME +planner=NAME")
    seed_everything(int(cfg.seed))
    spec = env_spec(cfg.env)
    testset, split = build_testset(cfg, spec)
    try:
        planner = hydra.utils.instantiate(cfg.planner)
    except InstantiationException as e:
        raise UsageError(f"config key planner: {e.__cause__ or e}") from None
    if cfg.planner.get("stop") == "cost" and any(q.reference_cost is None for q in testset.queries):
        raise UsageError("planner.stop=cost needs a reference cost for every query "
                         "(give `reference_cost` per query in a problem file)")
    run_dir = Path(hydra.core.hydra_config.HydraConfig.get().runtime.output_dir)
    info = run_info(cfg.env.name, cfg.planner.name, int(cfg.seed), split, OmegaConf.to_yaml(cfg, resolve=True))
    with TrialLog(run_dir, info, spec, rerun=bool(cfg.rerun), resume=bool(cfg.resume)) as log:
        try:
            records = run_bench(testset, planner, log, budget_s=float(cfg.budget_s),
                                validation_step=spec.validation_step,
                                collision=str(cfg.env.collision), progress=bool(cfg.progress), timing=timing)
        except KeyboardInterrupt:
            print(f"interrupted: every finished query is in {run_dir / 'trials.mcap'}", file=sys.stderr)
            raise
    print(f"{cfg.env.name} / {cfg.planner.name} / seed {cfg.seed}: {run_dir}")
    print(format_summary(summarize(records)) if records else "no queries to run")
    return records


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    from mpnet.problems import ProblemFileError

    try:
        bench(cfg)
    except (ProblemFileError, UsageError) as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    run_hydra(main, required=("env", "planner"))
