"""Reading trial logs: the trials.mcap files under the given directories into TrialFile objects and a
frame of their queries, with one warning line per file that is skipped, cut short or pooled with another.
The log format is read through harness.log."""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from harness.log import MCAP_NAME, read_log
from harness.log.facts import network_variant, run_facts
from harness.log.schemas import query_columns
from harness.report.names import env_rank, labelled

__all__ = [
    "QUERY_COLS",
    "TrialFile",
    "duplicate_warnings",
    "find_logs",
    "load",
    "queries_frame",
    "read_trials",
    "run_seed",
]

QUERY_COLS = query_columns()  # the /query fields a table holds, as the log's schema types them
NUMBER_COLS = query_columns("number", "integer")


@dataclass
class TrialFile:
    """One readable trials.mcap: its /run message, workspaces by (split, id), queries."""

    path: Path
    run: dict
    workspaces: dict[tuple[str, str], dict] = field(default_factory=dict)
    queries: list[dict] = field(default_factory=list)
    finalised: bool = True
    label: str | None = None  # the --label of its directory: its planner is shown as `planner [label]`
    recipe: bool = False  # the label is its networks' recipe (recipe_label), not a --label
    variant: bool = False  # the label names the settings that tell its planner's runs apart (label_variants)

    @property
    def planner(self) -> str:
        """The planner's name as the report shows it: the logged name, with the file's label."""
        return labelled(str(self.run["planner"]), self.label)


def find_logs(dirs: Iterable[str | Path]) -> tuple[list[Path], list[str]]:
    """Every trials.mcap under the given directories (a file path is taken as is), sorted and
    without duplicates; plus one warning per argument that is neither."""
    found, warns = {}, []
    for d in dirs:
        p = Path(d)
        if p.is_file():
            found.setdefault(p.resolve(), p)
        elif p.is_dir():
            for f in p.rglob(MCAP_NAME):
                if f.is_file():
                    found.setdefault(f.resolve(), f)
        else:
            warns.append(f"warning: {d}: no such file or directory")
    return sorted(found.values(), key=str), warns


def read_trials(path: Path) -> tuple[TrialFile | None, str | None]:
    """The file's contents, or None; and a one-line warning when it is skipped or cut short."""
    try:
        msgs, finalised = read_log(path, ("/run", "/workspace", "/query"))
    except Exception as e:  # noqa: BLE001 - unreadable for any reason: skipped, never a traceback
        return None, f"warning: skipped {path}: cannot read it ({type(e).__name__}: {e})"
    run, out = None, None
    for m in msgs:
        if m.topic == "/run":
            if run is None:
                run = m.data
                if not isinstance(run, dict) or not run.get("env") or not run.get("planner"):
                    return None, f"warning: skipped {path}: its /run message names no env or planner"
                out = TrialFile(path, run, finalised=finalised)
        elif out is None or not isinstance(m.data, dict):
            continue
        elif m.topic == "/query":
            out.queries.append(m.data)
        else:
            out.workspaces.setdefault((str(m.data.get("split")), str(m.data.get("workspace_id"))), m.data)
    if out is None:
        why = "no /run message" if msgs else "empty file" if _size(path) == 0 else "not a readable MCAP trial log"
        return None, f"warning: skipped {path}: {why}"
    notes = []
    if not finalised:
        notes.append(
            f"was not finalised (cut short or damaged): read the {len(out.queries)} queries it still holds; "
            f"`python -m harness.repair` makes it readable by other MCAP readers"
        )
    expected = out.run.get("queries_expected")
    logged = len({(str(q.get("split")), str(q.get("query_id"))) for q in out.queries})
    if isinstance(expected, int) and logged < expected:
        notes.append(
            f"incomplete run: {logged} of {expected} queries logged (the same command with resume=true finishes it)"
        )
    elif not out.queries:
        notes.append("no queries")
    return out, (f"warning: {path}: " + "; ".join(notes)) if notes else None


def _size(path: Path) -> int | None:
    try:
        return path.stat().st_size
    except OSError:
        return None


def run_seed(run: dict) -> int | None:
    """The /run message's seed when it is an integer, else None."""
    seed = run.get("seed")
    return seed if isinstance(seed, (int, np.integer)) and not isinstance(seed, (bool, np.bool_)) else None


def recipe_label(run: dict) -> str | None:
    """The label of a run whose planner trained its networks with recipe options its name does
    not say (`+planner=mpnet_nr +planner.networks.bounded=true`: `mpnet_nr [bounded]`), so that
    it is never pooled with the planner's plain runs; None for every other run."""
    facts = run.get("facts") if isinstance(run.get("facts"), dict) else {}
    config = facts.get("planner_config") if isinstance(facts.get("planner_config"), dict) else {}
    tags = network_variant(config.get("networks"))
    words = set(str(run.get("planner", "")).split("_"))
    unsaid = [t for t in tags if t not in words]
    return "+".join(unsaid) or None


def planner_settings(run: dict) -> str:
    """The run's planner config section as YAML text (its logged facts), or its whole config."""
    import yaml

    section = run_facts(run)["planner_config"]
    return yaml.safe_dump(section, sort_keys=False) if section is not None else str(run.get("config") or "")


def _variant(run: dict) -> str:
    """What makes a run's planner a variant of its own: every logged setting that decides
    results but the seed (a checker, a problem file, a budget, the planner's settings), as JSON;
    a log without settings, its planner section."""
    settings = run.get("settings")
    if not isinstance(settings, dict):
        return json.dumps({"planner.config": "sha256:" + hashlib.sha256(planner_settings(run).encode()).hexdigest()})
    return json.dumps({k: v for k, v in settings.items() if k != "seed"}, sort_keys=True, default=str)


def _short(v) -> str:
    """A setting's value in a planner's name: a digest by its first 8 hex digits."""
    text = v if isinstance(v, str) else json.dumps(v, default=str)
    if text.startswith("sha256:"):
        return text[7:15]
    return text if len(text) <= 32 else text[:29] + "..."


def variant_names(files: list[TrialFile], within_env: bool = False) -> list[str]:
    """Each file's planner as the database names it: its planner's name, and where runs of one
    planner differ in a setting other than the seed, the settings that tell them apart
    (`rrt_connect [env.collision=pybullet]`): Planner Arena groups runs by name, so two variants
    under one name would be shown as one planner with both variants' runs. within_env: runs
    compared only with the same planner's in the same env (the tables: a row is env x planner).
    A run of generated queries and one of a problem file are never compared: their queries
    are of other splits (seen/unseen against file), so no row or problem pools them."""
    variants = [_variant(tf.run) for tf in files]
    parsed = {v: json.loads(v) for v in variants}  # each distinct variant parsed once
    envs = [str(tf.run.get("env")) for tf in files]
    # a run given with --label (or its recipe's) is a planner of its own under that label, whatever
    # its settings: two revisions' runs of one planner were one planner of twice its runs
    names = [labelled(str(tf.run["planner"]), None if tf.variant else tf.label) for tf in files]
    keys = [
        (e if within_env else "", name, parsed[v].get("problems") is None) for e, name, v in zip(envs, names, variants)
    ]
    in_env: dict[tuple, list[dict]] = {}  # a key's variants in each env
    for k, e, v in dict.fromkeys(zip(keys, envs, variants)):
        in_env.setdefault((k, e), []).append(parsed[v])
    # the settings that tell a key's variants apart: those that differ within one env (across
    # envs, a planner's runs differ in the env's own settings, and are never pooled anyway: a
    # table's row and Planner Arena's experiment are one env), so one variant keeps one name in
    # every env (the database's planner configs)
    differ_of: dict[tuple, set[str]] = {}
    for (k, _), known in in_env.items():
        names = {n for d in known for n in d}
        differ_of.setdefault(k, set()).update(
            n for n in names if len({json.dumps(d.get(n), sort_keys=True, default=str) for d in known}) > 1
        )
    out = []
    for k, v in zip(keys, variants):
        differ = sorted(differ_of[k])
        if not differ:
            out.append(k[1])
            continue
        mine = parsed[v]
        out.append(f"{k[1]} [{', '.join(f'{n}={_short(mine.get(n))}' for n in differ)}]")
    return out


def label_variants(files: list[TrialFile]) -> None:
    """Unlabelled runs of one planner that differ in a setting that decides results (a checker,
    a problem file or subset, a budget, a planner setting) are labelled by those settings, as
    the Planner Arena database names them (`rrt_connect [env.collision=pybullet]`), so that no
    table row pools two variants' queries."""
    bare = [tf for tf in files if tf.label is None]
    for tf, name in zip(bare, variant_names(bare, within_env=True)):
        planner = str(tf.run["planner"])
        if name != planner:
            tf.label, tf.variant = name[len(planner) + 2 : -1], True


def load(
    dirs: Iterable[str | Path], labels: Iterable[tuple[str, str | Path]] = ()
) -> tuple[list[TrialFile], list[str], int]:
    """Readable trial files, warnings (one line each) and the number of files skipped. labels:
    (label, dir) pairs whose files carry that label (a file also under an unlabelled dir
    keeps its label), so that runs of different revisions or settings are never pooled; an
    unlabelled run of networks of its own recipe is labelled by it (recipe_label)."""
    label_of: dict[Path, tuple[Path, str | None]] = {}
    warns = []
    for label, d in [*labels, *((None, d) for d in dirs)]:
        found, w = find_logs([d])
        warns += w
        for p in found:
            label_of.setdefault(p.resolve(), (p, label))
    files, skipped = [], 0
    for p, label in sorted(label_of.values(), key=lambda pl: str(pl[0])):
        tf, w = read_trials(p)
        if w:
            warns.append(w)
        if tf is None:
            skipped += 1
            continue
        tf.label = label if label is not None else recipe_label(tf.run)
        tf.recipe = label is None and tf.label is not None
        files.append(tf)
        if tf.queries and run_seed(tf.run) is None:
            warns.append(
                f"warning: {p}: its /run has no integer seed ({tf.run.get('seed')!r}): "
                "its queries count as a seed of their own"
            )
    return files, warns, skipped


def _flag(v) -> float:
    """A logged boolean as 1.0 / 0.0, anything else (missing, null) as NaN."""
    return float(v) if isinstance(v, (bool, np.bool_)) else math.nan


def _numbers(col: pd.Series) -> pd.Series:
    """A column as floats; anything that is not a number (null, text, a list) becomes NaN."""
    try:
        return pd.to_numeric(col, errors="coerce").astype(float)
    except (TypeError, ValueError):
        return col.map(lambda v: float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan)


def queries_frame(files: list[TrialFile]) -> pd.DataFrame:
    """One row per logged query (no paths): the run's env, planner (as shown: with its label;
    logged_planner and run_label apart) and seed, the query's
    scalar fields, and (file, qidx) to find the full message again. A file without an
    integer seed gets a negative seed of its own, below every logged one, so that it is
    neither pooled with another file nor lost."""
    parts = []
    free_seed = min([s for s in map(run_seed, (tf.run for tf in files)) if s is not None] + [0]) - 1
    for i, tf in enumerate(files):
        if not tf.queries:
            continue
        df = pd.DataFrame.from_records(tf.queries, columns=list(QUERY_COLS))
        df["success"] = [_flag(v) == 1.0 for v in df["success"]]
        df["fallback_used"] = [_flag(v) for v in df["fallback_used"]]
        for c in NUMBER_COLS:
            df[c] = _numbers(df[c])
        df["target_planner"] = [v if isinstance(v, str) else None for v in df["target_planner"]]
        for c in ("query_id", "workspace_id", "split"):
            df[c] = df[c].astype(str)
        df["failure"] = df["failure"].astype(object).where(df["failure"].notna(), None)
        # Logs written before plan_s existed: time_s less MPNet's logged encode_s (what plan_s is)
        old = df["plan_s"].isna() & df["time_s"].notna()
        df.loc[old, "plan_s"] = df.loc[old, "time_s"] - df.loc[old, "encode_s"].fillna(0.0).clip(lower=0.0)
        df["file"] = i
        df["qidx"] = np.arange(len(df))
        df["env"] = str(tf.run["env"])
        df["planner"] = tf.planner
        df["logged_planner"] = str(tf.run["planner"])
        df["run_label"] = tf.label or ""
        seed = run_seed(tf.run)
        if seed is None:
            seed, free_seed = free_seed, free_seed - 1
        df["seed"] = int(seed)
        parts.append(df)
    if not parts:
        return pd.DataFrame(
            columns=list(QUERY_COLS) + ["file", "qidx", "env", "planner", "logged_planner", "run_label", "seed"]
        )
    df = pd.concat(parts, ignore_index=True)
    df["success"] = df["success"].astype(bool)
    return df


def duplicate_warnings(q: pd.DataFrame, files: list[TrialFile], facts) -> list[str]:
    """One line per (env, planner, seed) with queries (same split, workspace and query id)
    logged in more than one file: they all count, as documented, but it is seldom meant
    (e.g. a sweep run twice into different directories)."""
    key = ["env", "planner", "seed", "split", "workspace_id", "query_id"]
    per_file = q[key + ["file"]].drop_duplicates()
    d = per_file[per_file.duplicated(key, keep=False)]
    out = []
    groups = sorted(
        d.groupby(["env", "planner", "seed"], sort=False),
        key=lambda kv: (env_rank(kv[0][0]), facts.rank(kv[0][1]), kv[0][2]),
    )
    for (env, planner, seed), g in groups:
        n = len(g.drop_duplicates(key))
        names = ", ".join(str(files[i].path) for i in sorted(g["file"].unique()))
        out.append(
            f"warning: {env} {planner} seed {seed}: {n} queries logged in more than one file, all counted: {names}"
        )
    return out
