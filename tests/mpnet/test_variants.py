"""One rule for what makes MPNet a variant (mpnet.settings), read by the planner's name check
and by the logs' facts: every planner config, and the older shapes of them that logs hold,
gets the same facts and the same ablation verdict as the two rules it replaced (kept below
as they were, issue 44)."""

from __future__ import annotations

import pytest
from omegaconf import OmegaConf

from harness.core.cli import choices
from harness.log.facts import network_variant, planner_facts
from mpnet.settings import PAPER, ablation_of


def old_facts_variant(p: dict) -> str | None:
    """harness/log/facts.py's variant before the one rule."""
    variant = [] if p.get("proposal", "pnet") in ("pnet", None) else [str(p["proposal"])]
    if p.get("replanning", "forgiving") != "original":
        variant.append(str(p.get("replanning", "forgiving")))
    if p.get("anytime") is True:  # tags added since (issue 65): anytime, rounds<N>
        variant.append("anytime")
    if p.get("encoding") == "zeros":
        variant.append("zeros")
    if p.get("dropout") is False:
        variant.append("nodropout")
    if p.get("clip") is True:
        variant.append("clip")
    if p.get("compiled") is False:
        variant.append("numpy")
    if p.get("replan_rounds", 10) != 10:
        variant.append(f"rounds{p['replan_rounds']}")
    variant += network_variant(p.get("networks"))
    fallback = p.get("fallback", "rrt_star")
    if p["hybrid"] is True and fallback != "rrt_star":
        variant.append("rrtc" if fallback == "rrt_connect" else f"fallback_{fallback}")
    return "+".join(variant) or None


def old_ablation_of(proposal="pnet", encoding="cloud", dropout=True, replanning="original", clip=False) -> str:
    """mpnet/planners/neural.py's ablation_of before the one rule."""
    changed = [f"proposal={proposal}"] if proposal != "pnet" else []
    changed += ["clip=true"] if clip else []
    changed += [f"replanning={replanning}"] if replanning != "original" else []
    changed += [f"encoding={encoding}"] if encoding != "cloud" else []
    changed += ["dropout=false"] if not dropout else []
    return ", ".join(changed)


def _shapes(section: dict) -> list[dict]:
    """The section as configured, and as older logs hold it: without replanning (forgiving
    then), without compiled, without clip."""
    out = [section]
    out += [{k: v for k, v in section.items() if k != key} for key in ("replanning", "compiled", "clip")]
    return out


@pytest.fixture(scope="module")
def mpnet_sections(compose_config) -> dict:
    """Every MPNet planner section the configs compose (a cost target's included)."""
    out = {}
    for name in choices("planner"):
        section = OmegaConf.to_container(compose_config(["+env=s2d", f"+planner={name}"]).planner, resolve=True)
        for key, p in (("", section), ("@cost_target", section.get("cost_target"))):
            if isinstance(p, dict) and "hybrid" in p:
                out[name + key] = p
    return out


@pytest.mark.slow  # composes every planner config (~6 s): out of the fast loop
def test_every_mpnet_config_gets_the_facts_and_verdict_the_two_old_rules_gave(mpnet_sections):
    assert {"mpnet_nr", "mpnet_hr", "mpnet_hr_rrtc_clip", "mpnet_nr_numpy", "bit_star_to_nr@cost_target"} <= set(
        mpnet_sections
    )
    for name, section in mpnet_sections.items():
        for p in _shapes(section):
            assert planner_facts(p)["variant"] == old_facts_variant(p), (name, p)
        keys = ("proposal", "encoding", "dropout", "replanning", "clip")
        given = {k: section.get(k, getattr(PAPER, k)) for k in keys}
        old, new = old_ablation_of(**given), ablation_of(**given)
        assert sorted(old.split(", ")) == sorted(new.split(", ")), name  # the same settings named, in the rule's order


def test_every_combination_of_ablations_is_named_as_before():
    ablated = {"proposal": "straight", "encoding": "zeros", "dropout": False, "replanning": "forgiving", "clip": True}
    for mask in range(1 << len(ablated)):
        given = {k: v for i, (k, v) in enumerate(ablated.items()) if mask >> i & 1}
        assert sorted(ablation_of(**given).split(", ")) == sorted(old_ablation_of(**given).split(", ")), given


def test_another_number_of_rounds_and_anytime_are_tagged_and_described():
    from harness.report.names import describe_variant

    p = {"hybrid": False, "replanning": "original", "proposal": "random", "replan_rounds": 100, "anytime": True}
    assert planner_facts(p)["variant"] == "random+anytime+rounds100"
    assert planner_facts({**p, "replan_rounds": 10, "proposal": "pnet", "anytime": False})["variant"] is None
    words = describe_variant("random+anytime+rounds100").split("; ")
    assert words[0].startswith("a uniformly random valid state") and words[1].startswith("the paper's loop restarted")
    assert words[2] == "100 replanning rounds, not the paper's 10 (planner.replan_rounds)"
