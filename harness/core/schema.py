"""The typed schema the configs are checked against: each value's name, type, bounds and
meaning, written once (harness.core.config checks the YAML with `check_value`).

- `Recipe`: the networks' recipe, the training options that a planner's `networks` (and an
  env's `networks` and `paper_networks`, its default and the paper's) may set over the
  scale's; the options a recipe sets join the models' cache key (one left out keeps the key).
- `EnvKnobs` (and `ExpertKnobs`): the knobs of conf/env/*.yaml a user may type.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, Field, dataclass, field, fields

from omegaconf import OmegaConf

from harness.core.cli import UsageError
from mpnet.data.expert import CHECKS, EXPERTS, PAIRS
from mpnet.settings import EXPERT


def _option(
    kind: type,
    doc: str,
    *,
    minimum: float | None = None,
    below: float | None = None,
    choices: tuple = (),
    default=None,
    dagger=None,
):
    """A value: `kind` its type (list: layer widths; float: a positive finite number unless
    `minimum` is given); an integer's or a number's `minimum`; a number in [minimum, below)
    when `below` is given; one of `choices` (str); `default`: what an absent key means
    (None: unset); `dagger`: a recipe option's value when the recipe asks for DAgger's rounds
    and leaves it out."""
    meta = {"kind": kind, "doc": doc, "minimum": minimum, "below": below, "choices": choices, "dagger": dagger}
    return field(default=default, metadata=meta)


def number(key: str, value, positive: bool = True) -> None:
    """A finite number (positive unless told), or UsageError naming the key."""
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or (positive and value <= 0)
    ):
        raise UsageError(f"config key {key}: expected a {'positive ' if positive else ''}finite number, got {value!r}")


def integer(key: str, value, minimum: int) -> None:
    """An integer >= minimum, or UsageError naming the key."""
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise UsageError(f"config key {key}: expected an integer >= {minimum}, got {value!r}")


def check_value(key: str, value, meta) -> object:
    """`value` checked against its schema entry (a field's metadata): the value, typed, or
    UsageError naming the key in one line."""
    kind, minimum, below, choices = meta["kind"], meta["minimum"], meta["below"], meta["choices"]
    if choices:
        if value not in choices:
            raise UsageError(f"config key {key}: expected one of {', '.join(choices)}, got {value!r}")
        return str(value)
    if kind is bool:
        if not isinstance(value, bool):
            raise UsageError(f"config key {key}: expected true or false, got {value!r}")
        return value
    if below is not None:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not minimum <= value < below:
            raise UsageError(f"config key {key}: expected a number in [{minimum}, {below}), got {value!r}")
    elif kind is int:
        integer(key, value, 1 if minimum is None else minimum)
    elif kind is list:
        value = list(value) if OmegaConf.is_list(value) or isinstance(value, (list, tuple)) else value
        if (
            not isinstance(value, list)
            or not value
            or any(isinstance(v, bool) or not isinstance(v, int) or v < 1 for v in value)
        ):
            raise UsageError(f"config key {key}: expected a list of layer widths (integers >= 1), got {value!r}")
        return [int(v) for v in value]
    elif minimum is not None:
        number(key, value, positive=False)
        if value < minimum:
            raise UsageError(f"config key {key}: expected a number >= {minimum}, got {value}")
    else:
        number(key, value)
    return kind(value)


def check_section(node, schema, where: str) -> None:
    """Every field of dataclass `schema` that `node` (a config mapping) has, checked; a field
    whose type is itself a schema (`ExpertKnobs`) is checked inside its own section. Absent
    keys are left to their defaults."""
    for f in fields(schema):
        if f.name not in node or node[f.name] is None:
            if f.default is MISSING:  # required: an absent value is refused as a wrong one
                check_value(f"{where}.{f.name}", node.get(f.name), f.metadata)
            continue
        sub = f.metadata.get("section")
        if sub is not None:
            check_section(node[f.name], sub, f"{where}.{f.name}")
        else:
            check_value(f"{where}.{f.name}", node[f.name], f.metadata)


def value_of(node, schema, name: str):
    """`node`'s value of `schema`'s field `name`, or the field's default where the node lacks
    it (or holds null): the one place an absent key's meaning is written."""
    value = node.get(name) if node is not None else None
    if value is not None:
        return value
    default = next(f.default for f in fields(schema) if f.name == name)
    if default is MISSING:
        raise UsageError(f"config key {name}: required, and missing")
    return default


@dataclass(frozen=True)
class Recipe:
    """A named recipe of the networks (conf/env/*.yaml `networks`, `paper_networks`;
    conf/planner/*.yaml `networks`). docs/mpnet.md says what each was measured to do."""

    waypoint_step: float | None = _option(
        float, "expert paths resampled so that consecutive states are at most this far apart"
    )
    min_waypoints: int | None = _option(
        int, "... and have at least this many states (MoveIt's interpolation: 10)", minimum=2
    )
    equal_steps: bool | None = _option(
        bool, "Pnet's epochs scaled by (the scale's pairs / these pairs): as many gradient steps as the scale's"
    )
    bounded: bool | None = _option(bool, "Pnet's output softsign-bounded inside the state bounds (centred normaliser)")
    bidirectional: bool | None = _option(
        bool, "false: each path forward only (the public code's pairs); true adds the reversed path"
    )
    goal_pairs: str | None = _option(
        str,
        "Pnet's goal inputs: end (each path's end, the paper's) or all (every later waypoint: the intermediate goals "
        "bidirectional planning asks for)",
        choices=("end", "all"),
    )
    dropout: float | None = _option(
        float, "Pnet's dropout rate (the scale's model.dropout otherwise), at training and planning", minimum=0, below=1
    )
    input_noise: float | None = _option(
        float, "each training state moved by Gaussian noise of this standard deviation (state units; DART-style)"
    )
    collision_loss: float | None = _option(
        float,
        "Pnet's loss plus this weight times its proposals' depth in the scene's obstacles (metres; MπNets'; the arm)",
        minimum=0,
    )
    collision_motion: int | None = _option(
        int,
        "the collision loss measures this many states along the step to each proposal, ending at it (1: the proposal)",
        minimum=1,
    )
    pnet_hidden: list | None = _option(list, "Pnet's layer widths (the scale's otherwise)")
    enet_hidden: list | None = _option(list, "Enet's layer widths (the scale's otherwise)")
    latent: int | None = _option(int, "the scene code's size (the scale's otherwise)", minimum=1)
    voxels: int | None = _option(
        int, "Enet reads an occupancy grid of this many cells a side (order-free; trains end to end)", minimum=2
    )
    dagger_rounds: int | None = _option(
        int, "rounds of DAgger (harness.artifacts.dagger): each rolls out the round before's networks", minimum=1
    )
    dagger_queries: int | None = _option(
        int, "expert queries rolled out per training scene a round", minimum=1, dagger=5
    )
    dagger_states: int | None = _option(
        int, "states of each first NeuralPlanner run that the expert plans from", minimum=1, dagger=3
    )
    dagger_budget_s: float | None = _option(float, "the expert's budget per visited state (s)", dagger=2.0)


@dataclass(frozen=True)
class ExpertKnobs:
    """An env's `expert:` section (conf/env/*.yaml says each env's choice and why)."""

    iterations: int = _option(
        int, "RRT*'s iterations a path (rrt_connect*: runs a query, the shortest kept)", default=MISSING
    )
    max_seconds: float = _option(
        float, "the expert's time limit a run (rrt_connect* with run_iterations: the reference's only)", default=MISSING
    )
    run_iterations: int | None = _option(
        int,
        "rrt_connect*: a run's iteration budget, in place of its clock: paths that depend on the seed alone",
        minimum=1,
    )
    planner: str = _option(
        str,
        "the expert planner (rrt_connect_compiled: rrt_connect's recipe, its search compiled)",
        choices=tuple(EXPERTS),
        default=EXPERT.planner,
    )
    check: str = _option(str, "which checker a kept path must pass", choices=tuple(CHECKS), default=EXPERT.check)
    pairs: str = _option(str, "where the start/goal pairs come from", choices=tuple(PAIRS), default=EXPERT.pairs)
    chunk: int = _option(int, "scenes per expert process", minimum=1, default=EXPERT.chunk)
    blocked_only: bool = _option(
        bool, "only start/goal pairs whose straight line is blocked", default=EXPERT.blocked_only
    )
    contract: bool = _option(bool, "each expert path contracted (lazy states contraction)", default=EXPERT.contract)


@dataclass(frozen=True)
class EnvKnobs:
    """The knobs of an env's config that a user may type (conf/env/*.yaml; the env's fixed
    geometry is the registry's, mpnet.envs.specs). `collision` and `cloud` take what the
    env's robot offers (harness.core.config.check_env): collision one of its checkers, a camera
    cloud only for posed obstacles."""

    validation_step: float = _option(float, "the step of the fine re-check that decides success", default=MISSING)
    solvable_s: float | None = _option(
        float, "a generated test query is kept when RRT-Connect solves it this fast (an env with a generator)"
    )
    motion_step: float | None = _option(float, "collision=pybullet: motions sampled at this step")
    planner_range: float | None = _option(float, "OMPL's RRT-Connect / RRT* / Informed-RRT* maximum edge length")
    planning_margin: float | None = _option(float, "obstacles inflated by this much while planning", minimum=0)
    cloud: str = _option(
        str,
        "surface: points on every obstacle surface; camera: what a fixed depth camera sees",
        choices=("surface", "camera"),
        default="surface",
    )
    expert: ExpertKnobs | None = field(default=None, metadata={"section": ExpertKnobs})


OPTIONS: tuple[Field, ...] = fields(Recipe)
# DAgger's settings when a recipe asks for rounds and leaves them out (in the models key).
DAGGER_DEFAULTS = {f.name: f.metadata["dagger"] for f in OPTIONS if f.metadata["dagger"] is not None}
# A planner's `networks: {recipe: ...}`: the env's recipe (env.networks, the default) or the
# paper's for this env (env.paper_networks: the paper's arm recipe on the arm; the scale's own,
# which is the paper's, where an env has none).
RECIPES = {"env": "networks", "paper": "paper_networks"}
