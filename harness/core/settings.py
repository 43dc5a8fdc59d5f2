"""A run's settings, parsed once: typed and frozen, each part validated in one place (the
env's in EnvSettings.of, a planner's in PlannerSettings.of, the run's in settings_of), and
built once from the composed config by `settings_of`. Every stage after it (artifacts, the
bench, data, training, export) takes these, never the DictConfig.

The cache keys (data, models, test set) are computed here from the config exactly as they
always were (harness.core.config), so that a settings change can never move an artifact's key
without a test seeing it (tests/harness/core/test_settings.py pins them to the keys the config gave).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from harness.core.cli import UsageError
from harness.core.config import (
    check_env,
    check_planner,
    check_run,
    env_spec,
    geometry_params,
    lightning_params,
    make_planner,
    model_params,
    networks_params,
)
from harness.core.schema import ExpertKnobs, value_of
from harness.log.facts import facts_from_config
from mpnet.data.dataset import DataParams
from mpnet.data.expert_planners import TREE_EXPERTS
from mpnet.envs.spec import EnvSpec
from mpnet.settings import EXPERT

# Keys that change how a run is carried out, never what it finds: left out of `results`.
NOT_RESULTS = ("rerun", "resume", "progress", "cache_dir", "jobs", "hydra", "shard", "shards", "merge")


@dataclass(frozen=True)
class ExpertSettings:
    """How the env's expert paths are planned (env.expert)."""

    planner: str
    iterations: int
    max_seconds: float
    blocked_only: bool
    contract: bool
    chunk: int
    pairs: str = "env"  # mpnet.data.expert.PAIRS: the env's own start/goal pairs, or uniform
    check: str = "judge"  # mpnet.data.expert.CHECKS: what a kept path passes
    run_iterations: int | None = None  # rrt_connect: iterations a run (None: its clock alone)


@dataclass(frozen=True)
class EnvSettings:
    """The env's config: its geometry (spec, with the config's validation and motion steps)
    and the knobs of its data."""

    name: str
    spec: EnvSpec
    data_seed: int
    points_per_block: int
    solvable_s: float | None  # None: an env of problem files only
    collision: str
    expert: ExpertSettings | None  # None: an env of problem files only (no data to build)
    reference_bit_star_s: float | None
    geometry: dict = field(repr=False)  # the knobs in every data and test-set key (config.geometry_params)

    @classmethod
    def of(cls, env_cfg: DictConfig) -> EnvSettings:
        check_env(env_cfg)
        expert = env_cfg.get("expert")

        def knob(name: str):  # the config's value, or the schema's default for an absent key
            return value_of(expert, ExpertKnobs, name)

        reference = env_cfg.get("reference")
        return cls(
            name=str(env_cfg.name),
            spec=env_spec(env_cfg),
            data_seed=int(env_cfg.data_seed),
            points_per_block=int(env_cfg.points_per_block),
            solvable_s=None if env_cfg.get("solvable_s") is None else float(env_cfg.solvable_s),
            collision=str(env_cfg.collision),
            expert=None
            if expert is None
            else ExpertSettings(
                planner=str(knob("planner")),
                iterations=int(expert.iterations),
                max_seconds=float(expert.max_seconds),
                blocked_only=bool(knob("blocked_only")),
                contract=bool(knob("contract")),
                chunk=int(knob("chunk")),
                pairs=str(knob("pairs")),
                check=str(knob("check")),
                run_iterations=None if expert.get("run_iterations") is None else int(expert.run_iterations),
            ),
            reference_bit_star_s=None if reference is None else float(reference.bit_star_s),
            geometry=geometry_params(env_cfg),
        )

    def reference_params(self) -> dict:
        """What decides the test set's reference costs (none for exact ones)."""
        if self.spec.exact_reference:
            return {"iterations": 0, "expert_s": 0.0, "bit_star_s": 0.0}
        out = {"iterations": self.expert.iterations, "expert_s": self.expert.max_seconds}
        out["bit_star_s"] = self.reference_bit_star_s
        if self.expert.planner != EXPERT.planner:  # the RRT* expert's test sets keep their keys
            out["expert"] = self.expert.planner
        return out

    def cloud(self, workspace):
        """The workspace's point cloud as the networks were trained on it."""
        return self.spec.cloud(workspace, self.points_per_block, self.data_seed)


@dataclass(frozen=True)
class PlannerSettings:
    """A planner's config section, checked: what its `_target_` makes (MPNet's settings, or
    the planner itself), the bench's hooks (a cost target's planner, the networks' variant).
    name: the config's `name` (None when it has none: `label` asks the planner)."""

    name: str | None
    config: dict = field(repr=False)  # the section as composed, resolved: what make() instantiates
    key: str = "planner"
    networks: dict = field(default_factory=dict)
    stop: str | None = None
    cost_target: PlannerSettings | None = None

    @classmethod
    def of(cls, cfg: DictConfig, key: str, spec: EnvSpec, seed: int, networks: dict) -> PlannerSettings:
        section = OmegaConf.select(cfg, key)
        check_planner(section, key, spec, seed, str(cfg.env.collision))
        target = section.get("cost_target")
        return cls(
            name=str(section.name) if section.get("name") else None,
            config=OmegaConf.to_container(section, resolve=True),
            key=key,
            networks=networks,
            stop=None if section.get("stop") is None else str(section.stop),
            cost_target=None if target is None else cls.of(cfg, f"{key}.cost_target", spec, seed, {}),
        )

    def make(self, runtime: dict):
        """The planner, built in one step with the run's objects its settings name."""
        return make_planner(OmegaConf.create(self.config), self.key, runtime)

    def label(self, planner) -> str:
        """What logs and tables call the planner: its config's `name`, else the planner's own
        (a planner of one's own whose config has none), else the config's key."""
        return self.name or str(getattr(planner, "name", "") or self.key)


@dataclass(frozen=True)
class RunSettings:
    """One command's settings: the env, the planner (None for data, training and export),
    the run's own values, and the params that key its artifacts."""

    env: EnvSettings
    planner: PlannerSettings | None
    seed: int
    budget_s: float
    splits: tuple[str, ...]
    problems: str | None
    problems_per_set: int | None  # MotionBenchMaker: the first N problems of each set
    rerun: bool
    resume: bool
    progress: bool
    cache_dir: Path
    jobs: int
    shards: int
    shard: int | None
    merge: bool
    scale: str
    test_sizes: dict = field(repr=False)  # split -> (workspaces, queries per workspace)
    test_blocked_only: bool = True
    data: DataParams = field(default=None, repr=False)
    reference: dict = field(default_factory=dict, repr=False)
    models: dict = field(default_factory=dict, repr=False)
    lightning: dict = field(default_factory=dict, repr=False)
    config_yaml: str = field(default="", repr=False)  # the resolved config, as logged in /run
    results: dict = field(default_factory=dict, repr=False)  # dotted key -> value: what decides results
    facts: dict = field(default_factory=dict, repr=False)  # the report's facts (harness.log.facts)


def data_params(env: EnvSettings, train) -> DataParams:
    """Everything that decides the training dataset (its cache key): the env's data knobs and
    the scale's sizes (scale.train). The RRT-Connect expert plans with the env's planner
    range: then the data depends on it."""
    expert = env.expert
    planner_range = {"planner_range": env.spec.planner_range} if expert.planner in TREE_EXPERTS else {}
    return DataParams(
        env=env.name,
        data_seed=env.data_seed,
        points_per_block=env.points_per_block,
        train_workspaces=int(train.workspaces),
        paths_per_workspace=int(train.paths),
        ae_workspaces=int(train.ae_workspaces),
        expert_iterations=expert.iterations,
        expert_max_seconds=expert.max_seconds,
        expert_blocked_only=expert.blocked_only,
        expert_contract=expert.contract,
        geometry=env.geometry | planner_range,
        expert_chunk=expert.chunk,
        expert_planner=expert.planner,
        expert_pairs=expert.pairs,
        expert_check=expert.check,
        expert_run_iterations=expert.run_iterations,
    )


def file_digest(path: str | Path) -> str:
    """sha256 of a problem file; of a folder of them (MotionBenchMaker's), over every file's
    relative path and sha256, in sorted order."""
    path = Path(path)
    if not path.is_dir():
        with open(path, "rb") as f:
            return "sha256:" + hashlib.file_digest(f, "sha256").hexdigest()
    h = hashlib.sha256()
    for f in sorted(p for p in path.rglob("*") if p.is_file()):
        with open(f, "rb") as fh:
            h.update(str(f.relative_to(path)).encode() + b"\0" + hashlib.file_digest(fh, "sha256").digest())
    return "sha256:" + h.hexdigest()


def _flatten(value, prefix: str, out: dict) -> None:
    if isinstance(value, dict) and value:
        for k, v in value.items():
            _flatten(v, f"{prefix}.{k}" if prefix else str(k), out)
    else:
        out[prefix] = value


def results_settings(tree: dict) -> dict:
    """Dotted key -> value for every config value that decides results (a resumed run is
    held to them); the problem file counts by its content, not its path."""
    tree = {k: v for k, v in tree.items() if k not in NOT_RESULTS}
    if tree.get("problems"):
        tree["problems"] = file_digest(tree["problems"])
    out: dict = {}
    _flatten(tree, "", out)
    return out


def settings_of(cfg: DictConfig) -> RunSettings:
    """The composed config, checked and parsed once (UsageError naming the key)."""
    if "env" not in cfg:
        raise UsageError("choose an env with +env=NAME")
    check_run(cfg)
    env = EnvSettings.of(cfg.env)
    if env.spec.generator is None and not cfg.get("problems"):
        raise UsageError(f"config key problems: env {env.name} has no workspace generator; it plans problem files only")
    planner = None
    if cfg.get("planner") is not None:
        planner = PlannerSettings.of(cfg, "planner", env.spec, int(cfg.seed), networks_params(cfg))
    tree = OmegaConf.to_container(cfg, resolve=True)
    test = cfg.scale.test
    return RunSettings(
        env=env,
        planner=planner,
        seed=int(cfg.seed),
        budget_s=float(cfg.budget_s),
        splits=tuple(str(s) for s in cfg.splits),
        problems=str(cfg.problems) if cfg.get("problems") else None,
        problems_per_set=None if cfg.get("problems_per_set") is None else int(cfg.problems_per_set),
        rerun=bool(cfg.rerun),
        resume=bool(cfg.resume),
        progress=bool(cfg.progress),
        cache_dir=Path(str(cfg.cache_dir)),
        jobs=int(cfg.jobs),
        shards=int(cfg.get("shards", 1)),
        shard=None if cfg.get("shard") is None else int(cfg.shard),
        merge=bool(cfg.get("merge", False)),
        scale=str(cfg.scale.name),
        test_sizes={s: (int(test[s].workspaces), int(test[s].queries)) for s in ("seen", "unseen")},
        test_blocked_only=bool(test.get("blocked_only", True)),
        data=None if env.expert is None else data_params(env, cfg.scale.train),  # None: no data to build
        reference={} if env.expert is None else env.reference_params(),
        models=model_params(cfg),
        lightning=lightning_params(cfg),
        config_yaml=OmegaConf.to_yaml(cfg, resolve=True),
        results=results_settings(tree),
        facts=facts_from_config(tree, workspace_dim=env.spec.workspace_dim, robot=env.spec.robot.label),
    )
