"""The checks of the app's own keys, and what harness.core.settings derives from the config with
them: the env object and the model parameters (which are also cache keys). Typed values are
checked against their schema entries (harness.core.schema: the networks' recipe, the env's
knobs); the rules between keys are here.

A planner's settings are checked where its config's `_target_` makes them (one place: a
planner's constructor, or MPNet's MPNetSettings); the keys checked here are the app's:
budget, seed, splits, logging switches, the env's knobs, and the counts and sizes of data
and training. check_planner makes the planner's settings before any set-up (seeding
imports torch; MPNet's networks may need training); make_planner then builds the planner
in one step with the resolved networks.
"""

from __future__ import annotations

import inspect
from dataclasses import replace

from omegaconf import DictConfig, OmegaConf

from harness.core.cli import UsageError, missing_file
from harness.core.schema import (
    DAGGER_DEFAULTS,
    OPTIONS,
    RECIPES,
    EnvKnobs,
    ExpertKnobs,
    check_section,
    check_value,
    integer,
    number,
    value_of,
)
from mpnet.data.expert_planners import TREE_EXPERTS
from mpnet.envs.mbm.files import is_mbm
from mpnet.envs.scenes.camera import camera_cloud
from mpnet.envs.spec import EnvSpec
from mpnet.envs.specs import get_spec

# Env knobs that change what the checker answers (envs whose checker samples motions: the
# arm): they are part of every data and test-set cache key when the env config has them.
GEOMETRY_KEYS = ("motion_step", "planning_margin")


def _geometry(env_cfg) -> dict:
    return {k: float(env_cfg[k]) for k in GEOMETRY_KEYS if env_cfg.get(k) is not None}


def geometry_params(env_cfg) -> dict:
    """The config's geometry knobs, for cache keys. The validation step decides which
    expert paths are kept and the reference costs, so it is in the key too, but only when
    it differs from the env's registry value (existing caches keep their keys)."""
    spec = built_spec(env_cfg.name)
    out = _geometry(env_cfg) | spec.robot.cache_identity()
    if value_of(env_cfg, EnvKnobs, "cloud") != "surface":  # envs without the key keep their keys
        out["cloud"] = str(env_cfg.cloud)
    version = getattr(spec.generator, "VERSION", None)  # generators that version their output
    if version is not None:
        out["generator"] = f"{type(spec.generator).__name__}@{version}"
    step = env_cfg.get("validation_step")
    if step is not None and float(step) != built_spec(env_cfg.name).validation_step:
        out["validation_step"] = float(step)
    return out


def env_spec(env_cfg) -> EnvSpec:
    """The env's fixed geometry with the config's validation step (and motion step and
    planning margin, where the env has them)."""
    extra = _geometry(env_cfg)
    if value_of(env_cfg, EnvKnobs, "cloud") == "camera":
        extra["sample_cloud"] = camera_cloud
    if env_cfg.get("planner_range") is not None:  # not geometry: no data or test set depends on it
        extra["planner_range"] = float(env_cfg.planner_range)
    return replace(built_spec(env_cfg.name), validation_step=float(env_cfg.validation_step), **extra)


def built_spec(name: str) -> EnvSpec:
    """The registry's env, or a UsageError naming why it cannot be built here (its robot's files
    not installed, a broken robot file)."""
    try:
        return get_spec(name)
    except ValueError as e:
        raise UsageError(f"config key env: {e}") from None


# Counts and sizes a user may type: (key, smallest sensible value). A key a config lacks is
# skipped. Negative or zero counts were accepted silently before (jobs=-3 built with no workers).
INTEGER_KEYS = (
    ("jobs", 1),
    ("env.data_seed", 0),
    ("env.points_per_block", 1),
    ("scale.test.seen.workspaces", 1),
    ("scale.test.seen.queries", 1),
    ("scale.test.unseen.workspaces", 1),
    ("scale.test.unseen.queries", 1),
    ("scale.train.workspaces", 1),
    ("scale.train.paths", 1),
    ("scale.train.ae_workspaces", 0),
    ("scale.fit.ae_epochs", 0),
    ("scale.fit.pnet_epochs", 1),
    ("scale.fit.batch_size", 1),
    ("train.seed", 0),
    ("train.patience", 1),
)


def _check_training(cfg: DictConfig) -> None:
    """The counts, sizes and training knobs: what a typo would otherwise turn into hours of
    nonsense (a negative learning rate trains; jobs=-3 was accepted)."""
    for key, minimum in INTEGER_KEYS:
        value = OmegaConf.select(cfg, key, default=None)
        if value is not None:
            integer(key, value, minimum)
    if OmegaConf.select(cfg, "train.lr", default=None) is not None:
        number("train.lr", cfg.train.lr)
    if OmegaConf.select(cfg, "train.lam", default=None) is not None:
        number("train.lam", cfg.train.lam, positive=False)
        if cfg.train.lam < 0:
            raise UsageError(f"config key train.lam: expected a number >= 0, got {cfg.train.lam}")
    fraction = OmegaConf.select(cfg, "train.val_fraction", default=None)
    if fraction is not None:
        number("train.val_fraction", fraction)
        if not 0 < fraction < 1:
            raise UsageError(f"config key train.val_fraction: expected a number between 0 and 1, got {fraction}")


# Keys of a planner config that are the bench's, not the constructor's: the cost target's
# planner (time to equal quality) and the networks' training variant (`networks`).
PLANNER_HOOKS = ("cost_target", "networks")

# The networks' recipe options: their names, types and bounds (harness.core.schema).
NETWORK_KEYS = {f.name: f.metadata["kind"] for f in OPTIONS}
OPTION_BY_NAME = {f.name: f for f in OPTIONS}


def networks_params(cfg: DictConfig) -> dict:
    """The networks' recipe options, checked (UsageError naming the key): the recipe the
    planner names (`recipe`, env by default: env.networks), then the planner's own options
    over it key by key."""
    planner = cfg.get("planner")
    mine = _networks(planner.get("networks") if planner is not None else None, "planner.networks")
    key = RECIPES[mine.pop("recipe", "env")]
    env = cfg.get("env")
    base = _networks(env.get(key) if env is not None else None, f"env.{key}")
    if "recipe" in base:
        raise UsageError(f"config key env.{key}.recipe: an env's recipe cannot name another")
    out = base | mine
    if "dagger_rounds" in out:
        out = DAGGER_DEFAULTS | out
    elif any(k.startswith("dagger_") for k in out):
        raise UsageError("config key planner.networks.dagger_rounds: DAgger's settings given without its rounds")
    return out


def _networks(nets, where: str) -> dict:
    if nets is None:
        return {}
    if not OmegaConf.is_dict(nets):
        raise UsageError(f"config key {where}: expected a mapping of {', '.join(NETWORK_KEYS)}, got {nets!r}")
    out = {}
    for key, value in nets.items():
        name = f"{where}.{key}"
        if key == "recipe":
            if value not in RECIPES:
                raise UsageError(f"config key {name}: expected one of {', '.join(RECIPES)}, got {value!r}")
            out[key] = str(value)
            continue
        if key not in NETWORK_KEYS:
            raise UsageError(f"config key {name}: unknown (expected one of {', '.join(NETWORK_KEYS)}, recipe)")
        out[key] = check_value(name, value, OPTION_BY_NAME[key].metadata)
    return out


def _call(func, args: tuple, given: dict, runtime: dict, key: str):
    """func(*args, **given) plus the runtime objects its signature names; an unknown argument,
    or its ValueError/TypeError, becomes one line naming the key."""
    signature = inspect.signature(func)
    kwargs = {**given, **{k: v for k, v in runtime.items() if k in signature.parameters}}
    try:
        signature.bind(*args, **kwargs)
    except TypeError as e:
        raise UsageError(f"config key {key}: {e}") from None
    if callable(kwargs.get("models_dir")):  # the networks' folder, built on first use: resolved now
        kwargs["models_dir"] = kwargs["models_dir"]()
    try:
        return func(*args, **kwargs)
    except (ValueError, TypeError) as e:  # float("abc"), float(None): not every constructor names its key
        raise UsageError(str(e) if "config key" in str(e) else f"config key {key}: {e}") from None


def _settings(planner_cfg, key: str, runtime: dict):
    """What a planner config's `_target_` makes from its settings: the planner itself, or
    settings with a `build` (MPNet's: checked when made, built once the networks exist)."""
    import hydra
    from hydra.errors import InstantiationException

    args = {k: v for k, v in planner_cfg.items() if k not in PLANNER_HOOKS}
    try:
        factory = hydra.utils.instantiate(args, _partial_=True)
    except InstantiationException as e:
        raise UsageError(f"config key {key}: {e.__cause__ or e}") from None
    given = dict(factory.keywords)
    if "name" in given and not _takes(factory.func, "name"):
        del given["name"]  # the config's label for logs and tables (PlannerSettings.label), not a setting here
    return _call(factory.func, factory.args, given, runtime, key)


def _takes(func, keyword: str) -> bool:
    """Whether func accepts `keyword` (a parameter of that name, or **kwargs); True when its
    signature cannot be read (func then says itself)."""
    try:
        params = inspect.signature(func).parameters.values()
    except (TypeError, ValueError):
        return True
    return any(p.kind is p.VAR_KEYWORD or (p.name == keyword and p.kind is not p.POSITIONAL_ONLY) for p in params)


def make_planner(planner_cfg, key: str, runtime: dict):
    """The planner a config names, in one step: its settings, then, where they have a
    `build`, the planner built from them with the run's objects it names (env, seed, the
    networks' folder, resolved here, and cloud)."""
    made = _settings(planner_cfg, key, runtime)
    build = getattr(made, "build", None)
    return made if build is None else _call(build, (), {}, runtime, key)


def check_planner(planner_cfg, key: str, spec: EnvSpec, seed: int, collision: str | None = None) -> None:
    """The planner config's settings checked before any set-up (UsageError naming the key):
    MPNet's settings object is made (its networks are not needed) and, where it has a
    `check_env`, checked against the run's env; a planner without a `build` is constructed,
    unless it asks for the networks' folder (that would train)."""
    import hydra

    target = hydra.utils.get_method(planner_cfg["_target_"]) if "_target_" in planner_cfg else None
    if target is not None and "models_dir" in inspect.signature(target).parameters:
        return
    runtime = {"env": spec, "seed": seed, "cloud": lambda ws: None, "collision": collision}
    made = _settings(planner_cfg, key, runtime)
    check_env = getattr(made, "check_env", None)
    if check_env is not None:
        _call(check_env, (), {}, runtime, key)


def check_run(cfg: DictConfig) -> None:
    """The run's own values as a user types them (UsageError naming the key): budget, seed,
    splits, the problem file (it exists), switches, and the counts, sizes and knobs of data
    and training."""
    number("budget_s", cfg.budget_s)
    _check_training(cfg)
    if isinstance(cfg.seed, bool) or not isinstance(cfg.seed, int) or cfg.seed < 0:
        raise UsageError(f"config key seed: expected an integer >= 0, got {cfg.seed!r}")
    splits = cfg.splits
    if isinstance(splits, str) or not splits or any(s not in ("seen", "unseen") for s in splits):
        raise UsageError(
            f"config key splits: expected a list from [seen, unseen], e.g. splits=[seen], got "
            f"{OmegaConf.to_container(splits) if OmegaConf.is_config(splits) else splits!r}"
        )
    if message := missing_file("problems", cfg.get("problems")):
        raise UsageError(message)
    if (per_set := cfg.get("problems_per_set")) is not None:
        integer("problems_per_set", per_set, 1)
        if not cfg.get("problems") or not is_mbm(cfg.problems):
            raise UsageError(
                "config key problems_per_set: takes the first problems of each MotionBenchMaker problem set; "
                "give problems=<a folder of them>"
            )
    if cfg.env.get("scales") is not None and cfg.scale.name not in cfg.env.scales:
        raise UsageError(
            f"config key scale: env {cfg.env.name} has its sizes at scales {', '.join(cfg.env.scales)} "
            f"(conf/env_scale/{cfg.env.name}_*.yaml), got {cfg.scale.name!r}"
        )
    if not isinstance(cfg.scale.test.get("blocked_only", True), bool):
        raise UsageError(
            f"config key scale.test.blocked_only: expected true or false, got {cfg.scale.test.blocked_only!r}"
        )
    for key in ("rerun", "resume", "progress"):
        if not isinstance(cfg[key], bool):
            raise UsageError(f"config key {key}: expected true or false, got {cfg[key]!r}")
    _check_sharding(cfg)


def _check_sharding(cfg: DictConfig) -> None:
    """shards, shard and merge (harness.data's): UsageError naming the key."""
    shards, shard, merge = cfg.get("shards", 1), cfg.get("shard"), cfg.get("merge", False)
    if isinstance(shards, bool) or not isinstance(shards, int) or shards < 1:
        raise UsageError(f"config key shards: expected an integer >= 1, got {shards!r}")
    if shard is not None and (isinstance(shard, bool) or not isinstance(shard, int) or not 0 <= shard < shards):
        raise UsageError(f"config key shard: expected an integer in [0, shards={shards}), got {shard!r}")
    if not isinstance(merge, bool):
        raise UsageError(f"config key merge: expected true or false, got {merge!r}")
    if merge and shard is not None:
        raise UsageError(f"config key merge: merge=true assembles every shard; drop shard={shard}")


def check_env(env_cfg: DictConfig) -> None:
    """The env's knobs as a user types them (UsageError naming the key): each against its
    schema entry (harness.core.schema.EnvKnobs), then the rules between them and the robot's
    choices."""
    check_section(env_cfg, EnvKnobs, "env")
    if env_cfg.get("motion_step") is not None and env_cfg.validation_step * 10 > env_cfg.motion_step * (1 + 1e-9):
        raise UsageError(
            f"config key env.validation_step: the re-check must be at least 10x finer than env.motion_step "
            f"({env_cfg.motion_step}), got {env_cfg.validation_step}"
        )
    expert = env_cfg.get("expert")
    if (
        expert is not None
        and expert.get("run_iterations") is not None
        and value_of(expert, ExpertKnobs, "planner") not in TREE_EXPERTS
    ):
        raise UsageError(
            "config key env.expert.run_iterations: the rrt_connect experts' budget (rrt_star's: iterations)"
        )
    checkers = built_spec(env_cfg.name).robot.checkers
    if env_cfg.collision not in checkers:
        raise UsageError(f"config key env.collision: expected one of {', '.join(checkers)}, got {env_cfg.collision!r}")
    if value_of(env_cfg, EnvKnobs, "cloud") == "camera" and not built_spec(env_cfg.name).robot.posed_obstacles:
        raise UsageError(
            f"config key env.cloud: camera sees posed obstacles (the arm's envs); env {env_cfg.name} has surface only"
        )


def model_params(cfg: DictConfig) -> dict:
    """Everything that decides the trained networks (and so their cache key)."""
    m, f, t = cfg.scale.model, cfg.scale.fit, cfg.train
    params = {
        "format": "mpnet-bench/models@1",
        "enet_hidden": [int(x) for x in m.enet_hidden],
        "latent": int(m.latent),
        "pnet_hidden": [int(x) for x in m.pnet_hidden],
        "dropout": float(m.dropout),
        "ae_epochs": int(f.ae_epochs),
        "pnet_epochs": int(f.pnet_epochs),
        "batch_size": int(f.batch_size),
        "seed": int(t.seed),
        "lr": float(t.lr),
        "optimizer": str(t.optimizer),
        "lam": float(t.lam),
        "val_fraction": float(t.val_fraction),
        "patience": int(t.patience),
    }
    if f.get("end_to_end"):  # Enet trained with Pnet (the arm); absent otherwise, so other keys stay
        params["end_to_end"] = True
    if f.get("limit_batches") is not None:  # a dry run: a few batches per epoch
        params["limit_batches"] = int(f.limit_batches)
    if t.get("fused"):  # torch's fused optimiser step (absent: the keys stay)
        params["fused"] = True
    if f.get("scenes_per_batch") is not None:  # Pnet's batches from a few scenes each (absent: the keys stay)
        integer("scale.fit.scenes_per_batch", f.scenes_per_batch, 1)
        params["scenes_per_batch"] = int(f.scenes_per_batch)
    params |= networks_params(cfg)  # a planner's own networks (absent: the keys stay)
    if params.get("voxels") and not params.get("end_to_end"):
        raise UsageError(
            "config key networks.voxels (env.networks or planner.networks): a voxel Enet trains end to end "
            "with Pnet (scale.fit.end_to_end: true, the arm's); this scale pretrains Enet as an autoencoder"
        )
    if params.get("collision_motion") not in (None, 1) and not params.get("collision_loss"):
        raise UsageError(
            "config key networks.collision_motion (env.networks or planner.networks): it shapes the collision "
            "loss, and networks.collision_loss is not set"
        )
    robot = built_spec(cfg.env.name).robot
    if params.get("collision_loss") and not robot.offers_clearance:
        raise UsageError(
            f"config key networks.collision_loss (env.networks or planner.networks): env {cfg.env.name}'s robot "
            "offers no collision loss (the arms' envs do: a sphere model)"
        )
    return params


ENET_KEYS = ("enet_hidden", "latent", "ae_epochs", "batch_size", "seed", "lr", "optimizer", "lam", "val_fraction")
ENET_KEYS += ("patience", "limit_batches", "fused")


def enet_params(params: dict) -> dict | None:
    """What decides Enet's autoencoder alone (its own artifact's key, so that a fit cut
    short during Pnet keeps it); None where Enet trains with Pnet (`end_to_end`)."""
    if params.get("end_to_end"):
        return None
    return {"format": "mpnet-bench/enet@1", **{k: params[k] for k in ENET_KEYS if k in params}}


# Strategies that run the fit in worker processes of this one (Lightning's others re-run the
# command in each process, whose copies then wait on the model's build lock the first holds).
SPAWNING_STRATEGIES = ("ddp_spawn", "ddp_fork", "ddp_notebook")


def lightning_params(cfg: DictConfig) -> dict:
    """Lightning's settings from train.*, checked: several processes must be spawned ones,
    and on one node (the artifact store trains a model in one process and its children)."""
    t = cfg.train
    num_nodes, devices, strategy = t.get("num_nodes", 1), t.devices, str(t.strategy)
    if isinstance(num_nodes, bool) or not isinstance(num_nodes, int) or num_nodes != 1:
        raise UsageError(
            f"config key train.num_nodes: training spans one node (several GPUs of it with "
            f"train.strategy=ddp_spawn), got {num_nodes!r}"
        )
    count = len(devices) if OmegaConf.is_list(devices) else devices if isinstance(devices, int) else 1
    if count > 1 and strategy not in SPAWNING_STRATEGIES:
        raise UsageError(
            f"config key train.strategy: {count} devices need one of {', '.join(SPAWNING_STRATEGIES)} "
            f"(the others re-run this command per device), got {strategy!r}"
        )
    return {"accelerator": str(t.accelerator), "devices": devices, "strategy": strategy, "num_nodes": num_nodes}
