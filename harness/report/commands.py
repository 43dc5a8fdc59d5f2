"""The commands that made a report's logs, from the overrides each run logged (`/run`
`overrides`, as Hydra recorded the job's command line): runs that differ only in env, planner
and seed fold into one multirun command where they make its whole grid, so a report's README
says exactly how to run them again, not what such runs usually look like."""

from __future__ import annotations

import itertools
import shlex

SWEPT = ("+env", "+planner", "seed")


def _order(value: str):
    return (0, int(value), "") if value.lstrip("-").isdigit() else (1, 0, value)


def _command(rest: list[str], values: list[list[str]], jobs: int) -> str:
    swept = [f"{key}={','.join(v)}" for key, v in zip(SWEPT, values) if v]
    return shlex.join(["python", "-m", "harness", *(["-m"] if jobs > 1 else []), *swept, *rest])


def _fold(rest: list[str], combos: set[tuple]) -> list[str]:
    """One command for the grid of these (env, planner, seed) combos, or, where they are not a
    whole grid, one per env, then one per planner (whose seeds always are)."""
    values = [sorted({c[i] for c in combos if c[i] is not None}, key=_order) for i in range(len(SWEPT))]
    if set(itertools.product(*(v or [None] for v in values))) == combos:
        return [_command(rest, values, len(combos))]
    level = 0 if len(values[0]) > 1 else 1
    parts: dict = {}
    for c in combos:
        parts.setdefault(c[level], set()).add(c)
    return [cmd for key in sorted(parts, key=lambda k: _order(str(k))) for cmd in _fold(rest, parts[key])]


def sweep_commands(overrides: list[list[str] | None]) -> list[str] | None:
    """`python -m harness ...` lines that run every run again (each run's overrides, one list
    per run); None when a run did not log its overrides (logs written before they were)."""
    if not overrides or any(o is None for o in overrides):
        return None
    groups: dict[tuple, set] = {}
    for run in overrides:
        swept, rest = dict.fromkeys(SWEPT), []
        for o in run:
            key, _, value = str(o).partition("=")
            if key in swept:
                swept[key] = value
            else:
                rest.append(str(o))
        groups.setdefault(tuple(rest), set()).add(tuple(swept.values()))
    return [cmd for rest, combos in sorted(groups.items()) for cmd in _fold(list(rest), combos)]


# What a report names when its runs lack them: Table I's four planners, and MPNet-NR's
# ablations (conf/experiment/findings.yaml's), per env.
TABLE1_PLANNERS = ("mpnet_nr", "mpnet_hr", "informed_rrt_star", "bit_star")
NR_ABLATIONS = ("mpnet_nr_random", "mpnet_nr_random_any", "mpnet_nr_straight", "mpnet_nr_zeros", "mpnet_nr_nodropout")
PLANNER_NAMES = {
    "mpnet_nr": "MPNet (NR)",
    "mpnet_hr": "MPNet (HR)",
    "informed_rrt_star": "Informed-RRT*",
    "bit_star": "BIT*",
}


def missing_runs(runs: list[dict]) -> list[str]:
    """For each env of these runs (their /run messages), the Table I planners and the NR
    ablations it has no run of, each set with the one command that makes them: the same env,
    seeds and other overrides as the env's runs (the most common set of them). Empty when
    nothing is missing, or when a run did not log its overrides."""
    by_env: dict[str, list[dict]] = {}
    for r in runs:
        if not isinstance(r.get("overrides"), list):
            return []
        by_env.setdefault(str(r.get("env")), []).append(r)
    lines = []
    for env in sorted(by_env):
        rs = by_env[env]
        have = {str(r.get("planner")) for r in rs}
        seeds = sorted({str(r.get("seed")) for r in rs if r.get("seed") is not None}, key=_order)
        rests: dict[tuple, int] = {}
        for r in rs:
            rest = tuple(o for o in map(str, r["overrides"]) if o.partition("=")[0] not in SWEPT)
            rests[rest] = rests.get(rest, 0) + 1
        rest = list(max(rests, key=lambda k: (rests[k], k)))
        for what, planners in (("Table I's", TABLE1_PLANNERS), ("MPNet-NR's ablations", NR_ABLATIONS)):
            lacking = [p for p in planners if p not in have]
            if not lacking or (planners is NR_ABLATIONS and "mpnet_nr" not in have):
                continue  # ablations are asked for only beside MPNet-NR itself
            names = ", ".join(PLANNER_NAMES.get(p, p) for p in lacking)
            cmd = _command(rest, [[env], lacking, seeds], 2)
            lines.append(f"{env}: no runs of {what} {names}; to make them: {cmd}")
    return lines
