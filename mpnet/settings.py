"""MPNet's settings as plain data, written once: their defaults (MPNet as the paper runs it)
and what makes a planner a variant of it.

Read by the planner (mpnet.planners: MPNetPlanner's and MPNetSettings' defaults, and the
check that an ablation does not carry MPNet's own name) and by the logs (harness.log.facts:
a run's variant tags), so the two cannot disagree. No planner is imported here: the report,
which loads no planners, reads it through the facts.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from typing import NamedTuple


@dataclass(frozen=True)
class NeuralSettings:
    """MPNetPlanner's settings (mpnet.planners.neural) and their defaults: MPNetSettings, what a
    config makes, extends them; conf/planner/mpnet_nr.yaml spells them out for the logs
    (tests/harness/core/test_configs.py holds it to these)."""

    max_steps: int = 80
    replan_steps: int = 50
    replan_rounds: int = 10
    steer_steps: tuple | None = None
    proposal: str = "pnet"
    straight_step: float = 0.1
    fallback_restart_s: float | None = 0.5
    encoding: str = "cloud"
    dropout: bool = True
    replanning: str = "original"
    anytime: bool = False  # the paper's loop restarted (fresh dropout, fresh proposals) until the budget ends

    def shared(self) -> dict:
        """These settings by name (a subclass's own left out): what MPNetPlanner takes."""
        return {f.name: getattr(self, f.name) for f in fields(NeuralSettings)}


@dataclass(frozen=True)
class MPNetOptions(NeuralSettings):
    """The rest of MPNetSettings' settings and their defaults: HR (hybrid, with the OMPL planner
    `fallback`), Pnet's proposals clipped into the bounds (issue 26), the compiled loop (the
    configs' default; a library caller gets the numpy loop unless it asks: no kernels to compile)."""

    hybrid: bool = False
    fallback: str = "rrt_star"
    clip: bool = False
    compiled: bool = False


PAPER = MPNetOptions()


@dataclass(frozen=True)
class ExpertSettings:
    """How expert paths are made where an env's `expert:` section leaves a key out: the paper's
    expert (RRT*'s raw vertex list, start/goal pairs of the env's own kind, each kept path passed by
    the env's judge). Read by the data build (mpnet.data), the configs' schema
    (harness.core.schema) and the logs (harness.log.facts), so that they cannot disagree."""

    planner: str = "rrt_star"  # or rrt_connect, rrt_connect_compiled (mpnet.data.expert.EXPERTS)
    pairs: str = "env"  # or uniform (mpnet.data.expert.PAIRS)
    check: str = "judge"  # or planner (mpnet.data.expert.CHECKS)
    chunk: int = 1  # workspaces per expert process
    blocked_only: bool = True  # only start/goal pairs whose straight line is blocked
    contract: bool = False  # each path contracted


EXPERT = ExpertSettings()


class Variant(NamedTuple):
    key: str
    tag: Callable[[object], str | None]  # the setting's value -> its tag, None where it is the paper's
    ablation: bool  # it changes the method: an ablated planner may not carry MPNet's own name


def _unless(paper) -> Callable[[object], str | None]:
    """The value as its tag, unless it is the paper's (or unset)."""
    return lambda v: None if v in (paper, None) else str(v)


# In the order a variant's tags are joined. A config that omits a key has the paper's value
# (harness.log.facts fills in what older configs meant by omitting one).
VARIANTS = (
    Variant("proposal", _unless(PAPER.proposal), True),
    Variant("replanning", _unless(PAPER.replanning), True),
    Variant("anytime", lambda v: "anytime" if v is True else None, True),
    Variant("encoding", lambda v: "zeros" if v == "zeros" else None, True),
    Variant("dropout", lambda v: "nodropout" if v is False else None, True),
    Variant("clip", lambda v: "clip" if v is True else None, True),
    Variant("compiled", lambda v: "numpy" if v is False else None, False),  # the numpy reference: the same method
    # another number of replanning rounds (the paper's 10): tagged, so that its runs never read as the paper's
    Variant("replan_rounds", lambda v: None if v in (PAPER.replan_rounds, None) else f"rounds{v}", False),
)


def variant_tags(settings: Mapping, networks: Sequence[str] = ()) -> list[str]:
    """The tags that make MPNet with these settings (a config's planner section) a variant:
    VARIANTS' in order, the networks' own tags (the app's training options), then HR's
    fallback when it is not the paper's RRT*."""
    tags = [t for v in VARIANTS if (t := v.tag(settings.get(v.key))) is not None]
    tags += list(networks)
    fallback = settings.get("fallback", PAPER.fallback)
    if settings.get("hybrid") is True and fallback != PAPER.fallback:
        tags.append("rrtc" if fallback == "rrt_connect" else f"fallback_{fallback}")
    return tags


def ablation_of(**settings) -> str:
    """'' for MPNet as the paper (or a variant that only runs it otherwise), else the settings
    that ablate it, as a config writes them (e.g. 'proposal=random, dropout=false')."""
    ablated = [(v.key, settings[v.key]) for v in VARIANTS if v.ablation and v.tag(settings.get(v.key)) is not None]
    return ", ".join(f"{k}={str(x).lower() if isinstance(x, bool) else x}" for k, x in ablated)
