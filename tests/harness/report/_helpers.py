"""Known logs for the report's tests: trial logs written from a few lines each (write_log, Q),
the report run on them (report), and the statistics worked by hand."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from harness.core.cli import CONF_DIR
from harness.log import TrialLog
from harness.report.__main__ import main
from mpnet.envs.spaces import SE2Space
from mpnet.envs.specs import SPECS
from mpnet.envs.workspace import Workspace


def planner_section(name: str) -> dict:
    """The `planner` section conf/planner/<name>.yaml resolves to (its defaults list merged as Hydra
    does for these files), as a run logs it in its config."""
    raw = yaml.safe_load((CONF_DIR / "planner" / f"{name}.yaml").read_text())
    defaults = raw.pop("defaults", ["_self_"])
    out = {}
    for d in defaults if "_self_" in defaults else defaults + ["_self_"]:
        if d == "_self_":
            out.update(raw)
        else:
            parent, _, key = d.partition("@")
            out.update({key: planner_section(parent)} if key else planner_section(parent))
    return out


def planner_config(conf: str, **planner_kw) -> str:
    """A run's resolved config as YAML text: a budget and the planner section of conf/planner/<conf>.yaml
    (a bare `name: <conf>` for a planner not there), with planner_kw on top."""
    known = (CONF_DIR / "planner" / f"{conf}.yaml").exists()
    section = {**(planner_section(conf) if known else {"name": conf}), **planner_kw}
    return yaml.safe_dump({"budget_s": 10.0, "planner": section}, sort_keys=False)


def ws(env: str, wid: str, split: str) -> Workspace:
    wd = SPECS[env].workspace_dim
    return Workspace(wid, split, np.array([[0.0] * wd, [10.0] * wd]), np.array([[4.0] * wd, [3.0] * wd]))


def write_log(
    run_dir: Path,
    env: str,
    planner: str,
    seed,
    queries: list[dict],
    config: str | None = None,
    resume: bool = False,
    **run_kw,
) -> Path:
    """A trials.mcap with the given queries: dicts with split, wid, i, ok, t, and optional
    cost, checks and planner stats (any query field); paths run start -> (0, 15) -> goal."""
    spec = SPECS[env]
    d = spec.state_dim
    run = {
        "env": env,
        "planner": planner,
        "seed": seed,
        "split": "seen+unseen",
        "config": config or planner_config(planner),
        "git_rev": "abc1234",
        "versions": {"ompl": "2.0.1"},
        "host": "testhost",
        "started_at": "2026-11-21T12:00:00+00:00",
        **run_kw,
    }
    with TrialLog(run_dir, run, spec, rerun=False, resume=resume) as log:
        for q in queries:
            log.add_workspace(ws(env, q["wid"], q["split"]))
            start, mid, goal = np.full(d, -15.0), np.zeros(d), np.full(d, 15.0)
            mid[1] = 15.0
            if isinstance(spec.space, SE2Space):
                start[2], mid[2], goal[2] = 0.0, 1.0, 0.5
            rec = dict(
                query_id=f"{q['wid']}/{q['i']}",
                workspace_id=q["wid"],
                split=q["split"],
                start=start,
                goal=goal,
                success=q["ok"],
                failure=None if q["ok"] else q.get("failure", "timeout"),
                path=[start, mid, goal] if q["ok"] else [],
                time_s=q["t"],
                cpu_s=q["t"],
                path_cost=q.get("cost", 50.0) if q["ok"] else None,
                collision_checks=q.get("checks", 100),
                state_checks=1,
                motion_checks=1,
            )
            rec.update(q.get("stats", {}))
            log.add_query(rec)
    return run_dir / "trials.mcap"


def Q(split, wid, i, ok, t, **kw):
    return dict(split=split, wid=wid, i=i, ok=ok, t=t, **kw)


def report(tmp_path, *dirs, paper=False, labels=()):
    """python -m harness.report on dirs (labels: (name, dir) pairs given as --label) into tmp_path/out."""
    out = tmp_path / "out"
    labelled = [a for name, d in labels for a in ("--label", f"{name}={d}")]
    rc = main([str(d) for d in dirs] + labelled + ["--out", str(out)] + (["--paper"] if paper else []))
    return rc, out


def wilson_by_hand(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    p = k / n
    centre, half = (p + z * z / (2 * n)) / (1 + z * z / n), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return centre - half / (1 + z * z / n), centre + half / (1 + z * z / n)


def eq_config(name: str, factor: float | None = None) -> str:
    return planner_config(name) if factor is None else planner_config(name, cost_factor=factor)
