"""The env registry: each env is a file, `mpnet/data_files/envs/<name>.yaml` (docs/environments.md).
A file names its robot and workspace generator by class (`{class: module.Class, args: [...]}`),
its robot's state space by bounds (an arm's are its joint limits), and the fixed facts the
stages share (EnvSpec's fields). A new env, or a new robot of an existing kind, is a new file;
a new kind of robot adds its classes (robot, space, checker) and names them there.

In a file, a string "$robot" is the env's robot and "$generator.pairs" an attribute of its
generator (MotionBenchMaker's scenes draw their own queries). An env is built when first asked
for, not on import: an arm's env reads the robot's description (URDF, limits) to make its joint
space, which an s2d run never needs; envs naming the same robot share one robot object."""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping
from functools import cache
from importlib import resources
from typing import Any

import yaml

from mpnet.envs.spec import EnvSpec

ENVS = resources.files("mpnet") / "data_files" / "envs"
# EnvSpec's fields an env file may give beyond its robot, bounds and generator
FIELDS = ("workspace_dim", "blocks", "validation_step", "exact_reference", "sample_cloud", "motion_step",
          "planning_margin", "planner_range", "cloud_scale", "pairs")  # fmt: skip


def _imported(path: str) -> Any:
    """module.name -> the object (a class, a function)."""
    module, _, name = path.rpartition(".")
    return getattr(importlib.import_module(module), name)


def _frozen(value):
    """YAML lists as tuples: a robot's arguments are a cache key (one robot object per model)."""
    return tuple(_frozen(v) for v in value) if isinstance(value, list) else value


@cache
def _made(path: str, args: tuple) -> Any:
    return _imported(path)(*args)


def _resolve(value, built: dict):
    """'$robot' / '$generator.attr' -> what the file built so far; lists resolved item by item."""
    if isinstance(value, str) and value.startswith("$"):
        name, _, attr = value[1:].partition(".")
        return getattr(built[name], attr) if attr else built[name]
    if isinstance(value, list):
        return [_resolve(v, built) for v in value]
    return value


def _instance(node: dict, built: dict, shared: bool = False) -> Any:
    """{class, args}: the class called on its arguments (shared: one object per class and arguments)."""
    args = [_resolve(a, built) for a in node.get("args", [])]
    return _made(node["class"], _frozen(args)) if shared else _imported(node["class"])(*args)


def definitions() -> dict[str, dict]:
    """Every env file as read, by name, in their `order` (reports take `label` and the order)."""
    return {name: dict(d) for name, d in _definitions().items()}


def generated() -> list[str]:
    """The envs with a workspace generator, in order: those that data, training, generated queries
    and the tools' default sweeps are for (the others, `generator: null`, plan problem files only)."""
    return [name for name, d in _definitions().items() if d.get("generator") is not None]


@cache
def _definitions() -> dict[str, dict]:
    """Every env file, by name, in their `order`."""
    files = [f for f in ENVS.iterdir() if f.name.endswith(".yaml")]
    defs = {f.name.removesuffix(".yaml"): yaml.safe_load(f.read_text()) for f in files}
    return dict(sorted(defs.items(), key=lambda kv: (kv[1].get("order", 1 << 30), kv[0])))


def build(name: str, definition: dict) -> EnvSpec:
    """The EnvSpec an env file describes."""
    unknown = set(definition) - {"order", "label", "robot", "bounds", "generator", *FIELDS}
    if unknown:
        raise ValueError(f"env file {name}.yaml: unknown keys {', '.join(sorted(unknown))}")
    built: dict[str, Any] = {"robot": _instance(definition["robot"], {}, shared=True)}
    generator = definition.get("generator")  # null: an env of problem files only (no data to train on)
    built["generator"] = None if generator is None else _instance(generator, built)
    bounds = definition.get("bounds")
    space = built["robot"].space(None if bounds is None else tuple(tuple(float(v) for v in b) for b in bounds))
    fields = {k: _resolve(definition[k], built) for k in FIELDS if k in definition}
    if "sample_cloud" in fields:
        fields["sample_cloud"] = _imported(fields["sample_cloud"])
    if "cloud_scale" in fields:
        fields["cloud_scale"] = tuple(float(v) for v in fields["cloud_scale"])
    workspace_dim = fields.pop("workspace_dim")
    return EnvSpec(name, space, built["robot"], workspace_dim, built["generator"], **fields)


@cache
def _built(name: str) -> EnvSpec:
    return build(name, _definitions()[name])


class _Registry(Mapping[str, EnvSpec]):
    """The envs by name: names known at once, each EnvSpec built on first access, then the same object."""

    def __getitem__(self, name: str) -> EnvSpec:
        if name not in _definitions():
            raise KeyError(name)
        return _built(name)

    def __iter__(self) -> Iterator[str]:
        return iter(_definitions())

    def __len__(self) -> int:
        return len(_definitions())


SPECS: Mapping[str, EnvSpec] = _Registry()


def get_spec(name: str) -> EnvSpec:
    try:
        return SPECS[name]
    except KeyError:
        raise KeyError(f"unknown env {name!r}; choices: {', '.join(sorted(SPECS))}") from None
