"""A run's facts: what the report needs to know about a run, computed once from its resolved
config when the run starts and logged in `/run` (`facts`), so that the report never parses a
config again. Logs written before `facts` existed are read by `legacy_facts`, which computes the
same from the config text their `/run` holds (the only place that still parses it).

- planner: what kind of planner the run is (never read off its name, so a run keeps its place
  whatever it is called): `cost_target` a mapping, a time-to-equal-quality run of `algorithm`
  to reach MPNet (HR if the target is hybrid, else NR)'s cost times `cost_factor`; `hybrid`
  present, an MPNet run, base mpnet_hr if it is true, else mpnet_nr, and a variant of that
  base by MPNet's own rule (mpnet.settings.variant_tags: an ablation, the numpy loop, HR's
  fallback), a config without `replanning` replanning the forgiving way (it predates the key),
  or by its `networks` (network_variant);
  `algorithm`, a classical run; else a plain planner (a planner of one's own). None when
  the config has no `planner` mapping.
- budget_s, the training set's size (train_workspaces x train_paths asked, and, where the
  bench planned on networks whose dataset or shipped set says so, the paths built,
  training_paths_built: fewer where queries fail, as panda_mbm's), the expert and the
  reference's settings (expert_planner, expert_iterations, reference_bit_star_s), and, where
  the bench knows them, workspace_dim and robot; the scale's and the planner's config sections
  as they were (`scale`, `planner_config`: the report's provenance and Planner Arena's
  planner settings).
"""

from __future__ import annotations

import functools
import math

from mpnet.settings import EXPERT, variant_tags

FACTS_FORMAT = "mpnet-bench/facts@1"


def _get(cfg, *keys):
    for k in keys:
        if not isinstance(cfg, dict):
            return None
        cfg = cfg.get(k)
    return cfg


def _number(v) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        return None
    try:
        v = float(v)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def _int(v) -> int | None:
    n = _number(v)
    return int(n) if n is not None else None


def planner_facts(p) -> dict | None:
    """The planner's kind from its config section (see the module docstring)."""
    if not isinstance(p, dict):
        return None
    out = {"base": None, "variant": None, "algorithm": None, "target": None, "factor": None}
    target = p.get("cost_target")
    if isinstance(target, dict):
        out["algorithm"] = str(p.get("algorithm") or p.get("name") or "")
        out["target"] = "hr" if target.get("hybrid") is True else "nr"
        out["factor"] = _number(p.get("cost_factor")) or 1.0
        return out
    if "hybrid" in p:
        # MPNet's own rule (mpnet.settings); a config without `replanning` predates the key (its
        # runs replanned the forgiving way)
        variant = variant_tags({"replanning": "forgiving", **p}, network_variant(p.get("networks")))
        out["base"] = "mpnet_hr" if p["hybrid"] is True else "mpnet_nr"
        out["variant"] = "+".join(variant) or None
        return out
    if p.get("algorithm"):
        out["algorithm"] = str(p["algorithm"])
    return out


def network_variant(networks) -> list[str]:
    """The tags of a planner's own networks (its `networks:` recipe options): dense (resampled
    expert paths), bounded, forward (no reversed paths), allgoals (every later waypoint a goal
    input), dropout<rate>, noise<sd>, collision<weight> (a collision loss), sized (other
    network sizes), paper_recipe (the scale's recipe, not the env's), voxels<cells>
    (Enet reads a voxel grid of the cloud)."""
    if not isinstance(networks, dict):
        return []
    out = ["paper_recipe"] if networks.get("recipe") == "paper" else []
    if networks.get("waypoint_step") is not None or networks.get("min_waypoints") is not None:
        out.append("dense")
    if networks.get("bounded") is True:
        out.append("bounded")
    if networks.get("bidirectional") is False:
        out.append("forward")
    if networks.get("goal_pairs") == "all":
        out.append("allgoals")
    if networks.get("dropout") is not None:
        out.append(f"dropout{float(networks['dropout']):g}")
    if networks.get("input_noise"):
        out.append(f"noise{float(networks['input_noise']):g}")
    if networks.get("collision_loss"):
        out.append(f"collision{float(networks['collision_loss']):g}")
    if networks.get("collision_motion") not in (None, 1):
        out.append(f"motion{int(networks['collision_motion'])}")
    if any(networks.get(k) is not None for k in ("pnet_hidden", "enet_hidden", "latent")):
        out.append("sized")
    if networks.get("dagger_rounds"):
        out.append(f"dagger{int(networks['dagger_rounds'])}")
    if networks.get("voxels"):
        out.append(f"voxels{int(networks['voxels'])}")
    return out


def facts_from_config(cfg: dict, workspace_dim: int | None = None, robot: str | None = None) -> dict:
    """A run's facts from its resolved config (a plain dict)."""
    cfg = cfg if isinstance(cfg, dict) else {}
    return {
        "format": FACTS_FORMAT,
        "planner": planner_facts(cfg.get("planner")),
        "budget_s": _number(cfg.get("budget_s")),
        "train_workspaces": _int(_get(cfg, "scale", "train", "workspaces")),
        "train_paths": _int(_get(cfg, "scale", "train", "paths")),
        "training_paths_built": None,  # the bench sets it: the expert paths its networks were trained on
        "expert_planner": str(_get(cfg, "env", "expert", "planner") or EXPERT.planner) if "env" in cfg else None,
        "expert_iterations": _int(_get(cfg, "env", "expert", "iterations")),
        "reference_bit_star_s": _number(_get(cfg, "env", "reference", "bit_star_s")),
        "workspace_dim": workspace_dim,
        "robot": robot,
        "scale": cfg.get("scale") if isinstance(cfg.get("scale"), dict) else None,
        "planner_config": cfg.get("planner") if isinstance(cfg.get("planner"), dict) else None,
    }


def legacy_facts(run: dict) -> dict:
    """The facts of a `/run` message logged before `facts` existed: computed from its config
    text (the run's resolved Hydra config as YAML); every fact None when it is unreadable."""
    return _facts_of_config_text(str(run.get("config") or ""))


@functools.lru_cache(maxsize=256)
def _facts_of_config_text(text: str) -> dict:
    """Parsed once per config text: the report asks for an old run's facts from many places."""
    import yaml

    try:
        cfg = yaml.safe_load(text) or {}
    except yaml.YAMLError:
        cfg = {}
    return facts_from_config(cfg if isinstance(cfg, dict) else {})


def run_facts(run: dict) -> dict:
    """The facts of a `/run` message: logged ones, or, for an older log, legacy_facts."""
    facts = run.get("facts")
    if isinstance(facts, dict) and facts.get("format") == FACTS_FORMAT:
        return facts
    return legacy_facts(run)
