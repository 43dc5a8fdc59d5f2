"""Names, labels and orders the report shows: envs, splits, the paper's planners and its citation."""

from __future__ import annotations

import re

from mpnet.envs.specs import definitions

# the env files' order and labels (mpnet/data_files/envs); a log's env without a file: its name
ENV_ORDER = tuple(definitions())
ENV_LABELS = {name: d.get("label", name) for name, d in definitions().items()}
SPLIT_ORDER = ("seen", "unseen")
PAPER_PLANNERS = ("mpnet_nr", "mpnet_hr", "informed_rrt_star", "bit_star")
KNOWN_EXTRAS = ("rrt_star", "rrt_connect", "rrt_connect_compiled")
# The planners the report knows by name: label and figure colour.
PLANNERS = {
    "mpnet_nr": ("MPNet (NR)", "#1f77b4"),
    "mpnet_hr": ("MPNet (HR)", "#17becf"),
    "informed_rrt_star": ("Informed-RRT*", "#d62728"),
    "bit_star": ("BIT*", "#ff7f0e"),
    "rrt_star": ("RRT*", "#9467bd"),
    "rrt_connect": ("RRT-Connect", "#2ca02c"),
    "rrt_connect_compiled": ("RRT-Connect (compiled)", "#8c564b"),
}
PLANNER_LABELS = {name: label for name, (label, _) in PLANNERS.items()}
PLANNER_COLORS = {name: colour for name, (_, colour) in PLANNERS.items()}
RATIO_COL = "bit_star_over_mpnet_nr"
RATIO_LABEL = "BIT*/MPNet (NR)"
PAPER = 'Qureshi, Simeonov, Bency, Yip, "Motion Planning Networks", ICRA 2019, arXiv:1806.05767'
CITATION = (
    PAPER + ", Table I; their Informed-RRT* and BIT* were Python implementations, MPNet's times are "
    "CPU time on an i7 with a GTX 1080"
)
# The paper's sizes: train workspaces x expert paths, then seen and unseen test workspaces x
# queries per workspace; and its Pnet's hidden layers (to tell a smaller network).
PAPER_SCALE = (100, 4000, 100, 200, 10, 2000)
PAPER_SCALE_TEXT = "100 × 4000 paths; 100 × 200 seen, 10 × 2000 unseen"
PAPER_PNET_HIDDEN = (1280, 1024, 896, 768, 512, 384, 256, 256, 128, 64, 32)

# The key of a row of results.csv.
KEYS = ["env", "split", "planner"]

# Ablations of MPNet: a base (its config's `hybrid`) with one piece changed (facts.py reads which).
ABLATION_BASES = ("mpnet_nr", "mpnet_hr")
ABLATIONS = {
    "random": "a uniformly random valid state instead of Pnet's proposal",
    "random_any": "a uniformly random state (valid or not, as Pnet's) instead of Pnet's proposal",
    "forgiving": "CMPNet's forgiving replanning (a failed first run or segment is retried, not a failure)",
    "anytime": "the paper's loop restarted (fresh dropout and proposals) until the budget ends (planner.anytime)",
    "straight": "a fixed-length step toward the other tree's end instead of Pnet's proposal",
    "zeros": "Pnet given a zero workspace code",
    "nodropout": "Pnet deterministic (no dropout) at planning time",
    "rrtc": "RRT-Connect instead of the paper's RRT* as hybrid replanning's classical planner",
    "fallback_aorrtc": "OMPL's AORRTC (asymptotically optimal, bidirectional) instead of the paper's RRT* as hybrid "
    "replanning's classical planner",
    "clip": "Pnet's proposal clipped into the joint bounds (planner.clip)",
    "dense": "networks trained on the expert paths resampled at a fixed step (planner.networks.waypoint_step)",
    "bounded": "Pnet's output bounded inside the state bounds by a softsign (planner.networks.bounded)",
    "forward": "Pnet trained on each expert path forward only (planner.networks.bidirectional=false)",
    "allgoals": "Pnet trained toward every later waypoint of each expert path, not its end alone "
    "(planner.networks.goal_pairs=all)",
    "paper_recipe": "the networks of the paper's recipe, not the env's (planner.networks.recipe=paper)",
    "numpy": "the planning loop in numpy (planner.compiled=false), the reference the compiled default is tested "
    "against: the same method and answers, its time compared",
}


def describe_variant(variant: str) -> str:
    """A variant's change in words: each of its tags (joined by '+') as ABLATIONS says it;
    rounds<N>, N replanning rounds in place of the paper's 10."""
    words = []
    for tag in variant.split("+"):
        if tag.startswith("rounds") and tag[6:].isdigit():
            words.append(f"{tag[6:]} replanning rounds, not the paper's 10 (planner.replan_rounds)")
        else:
            words.append(ABLATIONS.get(tag, tag))
    return "; ".join(words)


# The mark of a difference that is not significant.
APPROX = "≈"


def labelled(planner: str, label: str | None) -> str:
    """A planner's name as shown for runs given with `--label label=DIR`: `bit_star [label]`."""
    return f"{planner} [{label}]" if label else planner


def env_rank(env: str) -> tuple:
    return (ENV_ORDER.index(env), "") if env in ENV_ORDER else (len(ENV_ORDER), env)


def split_rank(split: str) -> tuple:
    return (SPLIT_ORDER.index(split), "") if split in SPLIT_ORDER else (len(SPLIT_ORDER), split)


def env_label(env: str) -> str:
    return ENV_LABELS.get(env, env)


def natural_key(s: str) -> tuple:
    """'ws10-2' after 'ws9-3': digit runs compare as numbers (types line up by position)."""
    parts = re.split(r"(\d+)", str(s))
    return tuple(int(p) if i % 2 else p for i, p in enumerate(parts))
