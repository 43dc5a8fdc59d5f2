"""OUT/benchmark.db: the trial logs as an OMPL benchmark database (the schema of OMPL's benchmark
statistics script), so that Planner Arena (plannerarena.org) opens them.

Planner Arena plots every column of `runs` after the first three as an attribute, so `runs`
holds only numbers that exist for every run (no `memory`: not measured; a text column such as
the query id stalls its page); the query's ids, failure reason and seed are in the side table
`run_queries`. Each env is one experiment (name) with one row per split, and `split` is a
column after OMPL's twelve, which Planner Arena offers as a problem parameter (not `env`: the
experiment is the env, and Planner Arena 1.0.1's progress page fails on a parameter set to one
value, as a single-valued one always is). `progress`
holds the best cost over time of the queries whose planner logged it (OMPL's optimizing
planners: BIT*, Informed-RRT*, RRT*), sampled like OMPL's Benchmark samples it (see
progress_rows)."""

from __future__ import annotations

import math
import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd

from harness.log import run_segments
from harness.log.schemas import query_columns
from harness.report.facts import Facts, logged_facts
from harness.report.load import TrialFile, planner_settings, run_seed, variant_names

# OMPL's PlannerStatus, in the order its Benchmark writes the `status` enum.
OMPL_STATUS = (
    "Unknown status",
    "Invalid start",
    "Invalid goal",
    "Unrecognized goal type",
    "Timeout",
    "Approximate solution",
    "Exact solution",
    "Crash",
    "Abort",
    "Infeasible",
    "Invalid solution (failed the re-check)",  # ours: an exact path claimed, refused by the harness
    "Not run (no target: the planner it chases failed)",  # ours: a *_to_nr query whose NR failed
)
ST_UNKNOWN, ST_INVALID_START, ST_TIMEOUT, ST_EXACT, ST_CRASH, ST_ABORT, ST_RECHECK = 0, 1, 4, 6, 7, 8, 10
ST_NO_TARGET = 11
# Planner Arena takes the columns of `experiments` past OMPL's twelve as problem parameters.
PARAMETERS = (("split", "VARCHAR(64)"),)


_OMPL_COLUMNS = (  # OMPL's own run properties
    ("time", "REAL"),
    ("solved", "BOOLEAN"),
    ("status", "ENUM"),
    ("approximate_solution", "BOOLEAN"),
    ("correct_solution", "BOOLEAN"),
    ("solution_length", "REAL"),
    ("solution_segments", "INTEGER"),
    ("cpu_time", "REAL"),
)
# Ours: /query fields as they are, then MPNet's own (a classical planner logs none of these: it
# makes no Pnet call, replans and falls back never, so 0), each typed as the log's schema types it.
_QUERY_FIELDS = ("collision_checks", "state_checks", "motion_checks")
_MPNET_FIELDS = ("pnet_calls", "replans", "fallback_used")
_SQL_TYPES = {"integer": "INTEGER", "boolean": "BOOLEAN", "number": "REAL", "string": "TEXT"}
_RUN_COLUMNS = _OMPL_COLUMNS + tuple(
    (name, next(sql for kind, sql in _SQL_TYPES.items() if name in query_columns(kind)))
    for name in _QUERY_FIELDS + _MPNET_FIELDS
)


_SCHEMA = """
CREATE TABLE experiments
    (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512),
    totaltime REAL, timelimit REAL, memorylimit REAL, runcount INTEGER,
    version VARCHAR(128), hostname VARCHAR(1024), cpuinfo TEXT,
    date DATETIME, seed VARCHAR(24), setup TEXT);
CREATE TABLE plannerConfigs
    (id INTEGER PRIMARY KEY AUTOINCREMENT,
    name VARCHAR(512) NOT NULL, settings TEXT);
CREATE TABLE enums
    (name VARCHAR(512), value INTEGER, description TEXT,
    PRIMARY KEY (name, value));
CREATE TABLE runs
    (id INTEGER PRIMARY KEY AUTOINCREMENT, experimentid INTEGER, plannerid INTEGER,
    FOREIGN KEY (experimentid) REFERENCES experiments(id) ON DELETE CASCADE,
    FOREIGN KEY (plannerid) REFERENCES plannerConfigs(id) ON DELETE CASCADE);
CREATE TABLE progress
    (runid INTEGER, time REAL, best_cost REAL, best_quality REAL, PRIMARY KEY (runid, time),
    FOREIGN KEY (runid) REFERENCES runs(id) ON DELETE CASCADE);
CREATE TABLE run_queries
    (runid INTEGER PRIMARY KEY, seed INTEGER, split VARCHAR(64), workspace_id VARCHAR(256),
    query_id VARCHAR(256), failure VARCHAR(256),
    FOREIGN KEY (runid) REFERENCES runs(id) ON DELETE CASCADE);
"""


_VIEWS = """
CREATE VIEW bestPlannerConfigsPerExperiment AS
SELECT plannerid, experimentid, MIN(avg_solved) AS avg_solved, avg_total_time FROM
  (SELECT plannerid, plannerName, experimentid, AVG(solved) AS avg_solved, AVG(total_time) AS avg_total_time
   FROM (SELECT plannerid, plannerConfigs.name AS plannerName, experimentid, solved, time AS total_time
         FROM plannerConfigs INNER JOIN experiments INNER JOIN runs
         ON plannerConfigs.id=runs.plannerid AND experiments.id=runs.experimentid)
   GROUP BY plannerid, experimentid)
GROUP BY plannerName, experimentid ORDER BY avg_solved DESC, avg_total_time ASC;
CREATE VIEW bestPlannerConfigs AS
SELECT plannerid, MIN(avg_solved) AS avg_solved, avg_total_time FROM
  (SELECT plannerid, plannerName, AVG(solved) AS avg_solved, AVG(total_time) AS avg_total_time
   FROM (SELECT plannerid, plannerConfigs.name AS plannerName, experimentid, solved, time AS total_time
         FROM plannerConfigs INNER JOIN experiments INNER JOIN runs
         ON plannerConfigs.id=runs.plannerid AND experiments.id=runs.experimentid)
   GROUP BY plannerid)
GROUP BY plannerName ORDER BY avg_solved DESC, avg_total_time ASC;
"""


def ompl_status(success: pd.Series, failure: pd.Series) -> np.ndarray:
    """OMPL PlannerStatus values: exact solution for a success; for a failure timeout, invalid
    start, crash (an exception in the planner), abort (the planner gave up within the budget:
    OMPL's 'no solution for some other reason'), our invalid solution (a path that failed the
    harness's re-check), our not run (a cost-target query whose target planner failed: no
    target, nothing planned), or unknown."""
    f = failure.fillna("").astype(str)
    st = np.full(len(f), ST_UNKNOWN)
    st[f.eq("timeout").to_numpy()] = ST_TIMEOUT
    st[f.eq("invalid_query").to_numpy()] = ST_INVALID_START
    st[f.isin(("error", "exception", "crash")).to_numpy()] = ST_CRASH
    st[f.eq("no_solution").to_numpy()] = ST_ABORT
    st[f.str.startswith("recheck").to_numpy()] = ST_RECHECK
    st[f.eq("no_target").to_numpy()] = ST_NO_TARGET
    st[success.to_numpy(bool)] = ST_EXACT
    return st


def _none(v):
    """NaN to None (NULL); numpy scalars to Python ones."""
    if v is None:
        return None
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v.item() if isinstance(v, np.generic) else v


def _text(v) -> str | None:
    return None if v is None or (isinstance(v, float) and not math.isfinite(v)) else str(v)


def _path_len(v) -> int:
    return len(v) if isinstance(v, (list, tuple)) else 0


def _sql_int(x) -> int | str:
    """An integer for SQLite, which holds 64 bits: a larger one (a seed may be any size) as text."""
    v = int(x)
    return v if -(2**63) <= v < 2**63 else str(v)


# A run's best cost is sampled at most this many times (plus its end): OMPL's Benchmark samples
# every 0.05 s of a fixed budget; ours end anywhere from microseconds to the budget, so the
# period is each experiment's longest logged run over this.
PROGRESS_SAMPLES = 100


def progress_period(ends: list[float]) -> float:
    """The sampling period of an experiment's progress rows, from its runs' end times."""
    return max(max(ends, default=0.0) / PROGRESS_SAMPLES, 1e-6)


def progress_rows(runid: int, events, end_s: float, period: float, reference: float | None = None) -> list[tuple]:
    """(runid, time, best_cost, best_quality) every `period` seconds from 0 to the run's end,
    and at its end: the best cost of the last improvement logged by then (`events`: [time,
    cost] pairs in time order), NULL before the first solution; the rows OMPL's Benchmark
    writes for the planner property "best cost". best_quality is best_cost / the query's
    `reference` cost (NULL without one): an experiment holds many queries of different lengths,
    where OMPL's holds one problem, so only this ratio averages meaningfully across its runs."""
    if not events:
        return []
    t_ev = np.array([e[0] for e in events], float)
    c_ev = np.array([e[1] for e in events], float)
    end = max(float(end_s), float(t_ev[-1]))
    times = np.arange(0, int(end / period) + 1) * period
    if times[-1] < end:
        times = np.append(times, end)
    k = np.searchsorted(t_ev, times, side="right") - 1
    ref = float(reference) if reference is not None and math.isfinite(reference) and reference > 0 else None
    return [
        (runid, float(t), None if i < 0 else float(c_ev[i]), None if i < 0 or ref is None else float(c_ev[i]) / ref)
        for t, i in zip(times, k)
    ]


def write_benchmark_db(q: pd.DataFrame, files: list[TrialFile], path: Path, facts: Facts) -> int:
    """OUT/benchmark.db in the schema of OMPL's benchmark statistics script, so Planner Arena
    opens it: one experiment row per env x split (named by the env), one planner config per (planner name, settings)
    as that script keys them (runs of one planner with other settings get their own), one run
    per query. Replaces any earlier file. Returns the number of runs written."""
    if path.exists():
        path.unlink()
    conn = sqlite3.connect(path)
    try:
        c = conn.cursor()
        c.execute("PRAGMA FOREIGN_KEYS = ON")
        c.executescript(_SCHEMA)
        for name, typ in _RUN_COLUMNS:
            c.execute(f"ALTER TABLE runs ADD {name} {typ}")
        for name, typ in PARAMETERS:
            c.execute(f"ALTER TABLE experiments ADD {name} {typ}")
        c.executemany("INSERT INTO enums VALUES (?,?,?)", [("status", i, d) for i, d in enumerate(OMPL_STATUS)])
        names = variant_names(files)
        configs = [(name, planner_settings(tf.run)) for name, tf in zip(names, files)]
        config_ids = {}
        ranked = sorted(
            set(zip(configs, (str(tf.run["planner"]) for tf in files))), key=lambda k: (facts.rank(k[1]), k[0])
        )
        for (name, settings), _ in ranked:
            c.execute("INSERT INTO plannerConfigs (name, settings) VALUES (?,?)", (f"geometric_{name}", settings))
            config_ids[(name, settings)] = c.lastrowid
        file_config = [config_ids[k] for k in configs]
        if q.empty:
            conn.commit()
            return 0
        n = 0
        order = facts.sort(q[["env", "split"]].drop_duplicates(), ("env", "split"))
        for env, split in zip(order["env"], order["split"]):
            d = q[(q["env"] == env) & (q["split"] == split)]
            fruns = [files[i].run for i in sorted(d["file"].unique())]
            ompl = sorted(
                {
                    str(r["versions"]["ompl"])
                    for r in fruns
                    if isinstance(r.get("versions"), dict) and r["versions"].get("ompl") is not None
                }
            )
            logged_seed = np.array([run_seed(files[f].run) is not None for f in d["file"]], bool)
            budgets = {b for b in (logged_facts(r)["budget_s"] for r in fruns) if b is not None}
            segs = [seg for r in fruns for seg in run_segments(r)]
            started = sorted(str(s["started_at"]) for s in segs if s["started_at"] is not None)
            hosts = sorted({str(s["host"]) for s in segs if s["host"]})
            git = sorted({str(s["git_rev"]) for s in segs if s["git_rev"]})
            c.execute(
                "INSERT INTO experiments (name, totaltime, timelimit, memorylimit, runcount, version, hostname,"
                " cpuinfo, date, seed, setup, split) VALUES (?,?,?,?,?,?,?,?,?,?,?,?)",
                (
                    str(env),
                    float(np.nansum(d["time_s"])),
                    max(budgets) if budgets else None,
                    0.0,
                    int(len(d[["workspace_id", "query_id", "seed"]].drop_duplicates())),  # each (query, seed) once
                    "OMPL " + (",".join(ompl) or "unknown"),
                    ", ".join(hosts),
                    None,
                    started[0] if started else None,
                    ",".join(str(s) for s in sorted(d.loc[logged_seed, "seed"].unique())),
                    f"mpnet-bench trial logs: env {env}, split {split}, git {', '.join(git) or 'unknown'}",
                    str(split),
                ),
            )
            exp_id = c.lastrowid
            ok = d["success"].to_numpy(bool)
            status = ompl_status(d["success"], d["failure"])
            plen = np.array([_path_len(files[f].queries[i].get("path")) for f, i in zip(d["file"], d["qidx"])], int)
            cols = {
                "time": d["time_s"],
                "solved": ok.astype(int),
                "status": status,
                "approximate_solution": np.zeros(len(d), int),
                "correct_solution": ok.astype(int),
                "solution_length": d["path_cost"].where(ok),
                "solution_segments": np.where(ok & (plen > 0), np.maximum(plen - 1, 0), np.nan),
                "cpu_time": d["cpu_s"],
                **{name: d[name] for name in _QUERY_FIELDS},
                **{name: d[name].fillna(0) for name in _MPNET_FIELDS},
            }
            ints = {"solution_segments", *query_columns("integer", "boolean")}  # fallback_used: 0 or 1
            data = [[exp_id] * len(d), [file_config[f] for f in d["file"]]]
            for name, _ in _RUN_COLUMNS:
                v = np.asarray(cols[name], dtype=object)
                data.append(
                    [
                        None
                        if x is None or (isinstance(x, float) and not math.isfinite(x))
                        else (_sql_int(x) if name in ints else _none(x))
                        for x in v
                    ]
                )
            names = ["experimentid", "plannerid"] + [n for n, _ in _RUN_COLUMNS]
            first = c.execute("SELECT COALESCE(MAX(id), 0) FROM runs").fetchone()[0] + 1
            ids = list(range(first, first + len(d)))
            c.executemany(
                f"INSERT INTO runs (id,{','.join(names)}) VALUES (?,{','.join('?' * len(names))})",
                list(zip(ids, *data)),
            )
            events = [files[f].queries[i].get("progress") for f, i in zip(d["file"], d["qidx"])]
            refs = d["reference_cost"] if "reference_cost" in d else pd.Series(np.nan, index=d.index)
            logged = [x for x in zip(ids, events, d["time_s"], refs) if x[1] and math.isfinite(x[2])]
            period = progress_period([t for _, _, t, _ in logged])
            for runid, e, t, ref in logged:
                c.executemany("INSERT INTO progress VALUES (?,?,?,?)", progress_rows(runid, e, t, period, ref))
            seeds = [None if not ok_seed else _sql_int(s) for s, ok_seed in zip(d["seed"], logged_seed)]
            c.executemany(
                "INSERT INTO run_queries VALUES (?,?,?,?,?,?)",
                list(zip(ids, seeds, *(d[k].map(_text) for k in ("split", "workspace_id", "query_id", "failure")))),
            )
            n += len(d)
        c.executescript(_VIEWS)
        conn.commit()
        return n
    finally:
        conn.close()
