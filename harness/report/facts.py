"""What kind of planner a run is, read from its `/run` config (the resolved YAML it logs),
never parsed out of its name: an MPNet ablation (which piece it replaces) or a
time-to-equal-quality run (which algorithm, toward which MPNet, at which factor).

`load` registers every run's facts by planner name; the tables ask `facts_of(name)`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass


def run_config(run: dict) -> dict:
    """A run's resolved config (its YAML text) as a dict; {} when it is not one."""
    import yaml

    try:
        cfg = yaml.safe_load(str(run.get("config") or "")) or {}
    except yaml.YAMLError:
        return {}
    return cfg if isinstance(cfg, dict) else {}


def cfg_get(cfg: dict, *keys):
    for k in keys:
        if not isinstance(cfg, dict):
            return None
        cfg = cfg.get(k)
    return cfg


def finite_number(v) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        return None
    try:
        v = float(v)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def budget_of(config: str) -> float | None:
    m = re.search(r"^budget_s:\s*([0-9.eE+-]+)\s*$", str(config or ""), re.MULTILINE)
    try:
        return float(m.group(1)) if m else None
    except ValueError:
        return None


@dataclass(frozen=True)
class PlannerFacts:
    """ablation: (base, variant), e.g. ("mpnet_nr", "random"); equal_quality: (algorithm,
    target "nr"/"hr", factor or None for 1)."""

    ablation: tuple[str, str] | None = None
    equal_quality: tuple[str, str, float | None] | None = None


PLAIN = PlannerFacts()
_FACTS: dict[str, PlannerFacts] = {}


def facts_from_config(planner) -> PlannerFacts:
    """An MPNet config has `hybrid`; an ablation changes `proposal`, `encoding` or
    `dropout`; a time-to-equal-quality config has a `cost_target` planner."""
    if not isinstance(planner, dict):
        return PLAIN
    target = planner.get("cost_target")
    if isinstance(target, dict):
        factor = finite_number(planner.get("cost_factor"))
        return PlannerFacts(
            equal_quality=(
                str(planner.get("algorithm")),
                "hr" if target.get("hybrid") else "nr",
                None if factor in (None, 1.0) else factor,
            )
        )
    if "hybrid" not in planner:
        return PLAIN
    variants = []
    if planner.get("proposal", "pnet") != "pnet":
        variants.append(str(planner["proposal"]))
    if planner.get("encoding", "cloud") != "cloud":
        variants.append(str(planner["encoding"]))
    if planner.get("dropout", True) is False:
        variants.append("nodropout")
    if not variants:
        return PLAIN
    return PlannerFacts(ablation=("mpnet_hr" if planner.get("hybrid") else "mpnet_nr", "+".join(variants)))


def learn(runs: Iterable[dict]) -> None:
    """Register the facts of each run's planner (from its config) under its logged name."""
    for run in runs:
        if run.get("planner") is not None:
            _FACTS[str(run["planner"])] = facts_from_config(run_config(run).get("planner"))


def facts_of(planner: str) -> PlannerFacts:
    """The registered facts of a planner (plain when no run of it was loaded)."""
    return _FACTS.get(planner, PLAIN)
