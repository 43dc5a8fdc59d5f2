"""Problem files: bring your own workspaces and queries (docs/environments.md, "Problem files").

    {
      "format": "mpnet-bench/problems@1",
      "env": "s2d",
      "workspaces": [
        {"id": "narrow-gap",
         "obstacles": [{"center": [0.0, 5.0], "size": [5.0, 5.0]}],
         "queries": [{"start": [-15.0, -15.0], "goal": [15.0, 15.0]}]}
      ]
    }

`load_problems` validates the whole file before returning anything, and every problem
with it raises `ProblemFileError`, whose message is one line naming the file and, where
it applies, the workspace (id and index) and the query (index), e.g.

    problems.json: workspace 'narrow-gap' (#0), query #2: goal has 3 numbers, env s2d needs 2

A start or goal that is in collision or out of bounds is *not* a format error: the
planner logs such a query as a failure with reason `invalid_query`, so no collision or
bounds checks happen here. Unknown extra keys are ignored.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from mpnet.envs.shapes import IDENTITY, TYPES, Primitive
from mpnet.envs.spec import SPLIT, EnvSpec, ProblemFileError, TestSet
from mpnet.envs.specs import SPECS
from mpnet.envs.workspace import Query, Workspace

FORMAT = "mpnet-bench/problems@1"
# @2 adds posed primitives to 3D workspaces: {"type": box|cylinder|sphere, "center", "size"
# (a cylinder's [diameter, diameter, height], a sphere's [diameter] * 3), "orientation"
# [x, y, z, w]}; an obstacle without type and orientation is an axis-aligned box, as in @1.
FORMAT_2 = "mpnet-bench/problems@2"

__all__ = [
    "FORMAT",
    "FORMAT_2",
    "SPLIT",
    "ProblemFileError",
    "load_problems",
    "dump_problems",
    "dumps_problems",
    "problems_document",
    "query_id",
]


def query_id(workspace_id: str, index: int) -> str:
    """The stable id of query `index` of workspace `workspace_id`."""
    return f"{workspace_id}/{index}"


# --------------------------------------------------------------------------- parsing


class _NonFinite:
    """Stands in for a NaN/Infinity literal (or an overflowing number) while parsing, so
    the validator can say exactly where it was."""

    __slots__ = ("text",)

    def __init__(self, text: str):
        self.text = text

    def __repr__(self):
        return self.text


def _parse_float(text: str):
    x = float(text)
    return x if math.isfinite(x) else _NonFinite(text)


def _read_json(path) -> Any:
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except FileNotFoundError:
        raise ProblemFileError(path, "cannot read the file: no such file") from None
    except IsADirectoryError:
        raise ProblemFileError(path, "cannot read the file: it is a directory") from None
    except UnicodeDecodeError as e:
        raise ProblemFileError(path, f"not UTF-8 text (byte {e.start}): {e.reason}") from None
    except OSError as e:
        raise ProblemFileError(path, f"cannot read the file: {e.strerror or e}") from None
    try:
        return json.loads(text, parse_constant=_NonFinite, parse_float=_parse_float)
    except json.JSONDecodeError as e:
        raise ProblemFileError(path, f"not valid JSON: {e.msg} at line {e.lineno} column {e.colno}") from None
    except RecursionError:
        raise ProblemFileError(path, "not valid JSON: nested too deeply") from None
    except ValueError as e:  # e.g. an integer literal with too many digits
        raise ProblemFileError(path, f"not valid JSON: {e}") from None


# --------------------------------------------------------------------------- validation


def _type_name(v) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, (int, float)):
        return "a number"
    if isinstance(v, list):
        return "a list"
    if isinstance(v, dict):
        return "an object"
    if isinstance(v, _NonFinite):
        return "a non-finite number"
    return type(v).__name__


def _got(v) -> str:
    """'a string ("3")' -- the kind of a JSON value and a short excerpt of it."""
    if v is None:
        return "null"
    return f"{_type_name(v)} ({_show(v)})"


def _show(v, limit: int = 40) -> str:
    try:  # a NaN or Infinity may sit anywhere inside v (1e999 shown as Infinity)
        s = json.dumps(v, default=lambda x: float(x.text)) if not isinstance(v, _NonFinite) else v.text
    except (RecursionError, ValueError):  # nested too deeply to show, or an integer too long to print
        s = _type_name(v)
    return s if len(s) <= limit else s[: limit - 3] + "..."


class _Checker:
    def __init__(self, path, spec: EnvSpec):
        self.path = path
        self.spec = spec
        self.wi: int | None = None
        self.wid: str | None = None
        self.qi: int | None = None
        self.where: str | None = None

    def fail(self, detail: str):
        raise ProblemFileError(
            self.path, detail, workspace_index=self.wi, workspace_id=self.wid, query_index=self.qi, where=self.where
        )

    def obj(self, v, what: str) -> dict:
        if not isinstance(v, dict):
            self.fail(f"{what} must be an object, got {_type_name(v)}")
        return v

    def key(self, d: dict, k: str, what: str | None = None):
        if k not in d:
            self.fail(f"missing key {k!r}" + (f" in {what}" if what else ""))
        return d[k]

    def lst(self, v, what: str) -> list:
        if not isinstance(v, list):
            self.fail(f"{what} must be a list, got {_got(v)}")
        return v

    def number(self, v, what: str) -> float:
        if isinstance(v, _NonFinite):
            self.fail(f"{what} is {v.text}; NaN and infinite numbers are not allowed")
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.fail(f"{what} must be a number, got {_got(v)}")
        try:
            x = float(v)
        except OverflowError:
            x = math.inf
        if not math.isfinite(x):
            self.fail(f"{what} is {_show(v)}, which is not a finite number")
        return x

    def vector(self, v, what: str, dim: int, dim_name: str) -> list[float]:
        if not isinstance(v, list):
            self.fail(f"{what} must be a list of {dim} numbers, got {_got(v)}")
        xs = [self.number(x, f"{what}[{i}]") for i, x in enumerate(v)]
        if len(xs) != dim:
            n = "1 number" if len(xs) == 1 else f"{len(xs)} numbers"
            self.fail(f"{what} has {n}, env {self.spec.name} needs {dim} ({dim_name})")
        return xs


def _check_document(doc, path, spec: EnvSpec) -> TestSet:
    c = _Checker(path, spec)
    if not isinstance(doc, dict):
        c.fail(f"the top level must be a JSON object, got {_type_name(doc)}")

    if "format" not in doc:
        c.fail(f"missing key 'format' (expected {FORMAT!r} or {FORMAT_2!r})")
    if doc["format"] not in (FORMAT, FORMAT_2):
        c.fail(f"format is {_show(doc['format'])}, expected {FORMAT!r} or {FORMAT_2!r}")
    posed = doc["format"] == FORMAT_2

    if "env" not in doc:
        c.fail(f"missing key 'env' (the env this file is for; one of {', '.join(sorted(SPECS))})")
    env = doc["env"]
    if not isinstance(env, str):
        c.fail(f"env must be a string, got {_got(env)}")
    if env != spec.name:
        if env not in SPECS:
            c.fail(f"unknown env {env!r}; choices: {', '.join(sorted(SPECS))}")
        c.fail(
            f"the file is for env {env!r} but env {spec.name!r} was chosen; "
            f"run with +env={env} or use a file for {spec.name}"
        )

    raw_ws = c.lst(c.key(doc, "workspaces"), "workspaces")
    if not raw_ws:
        c.fail("workspaces is empty; the file needs at least one workspace")

    workspaces: list[Workspace] = []
    queries: list[Query] = []
    seen_ids: dict[str, int] = {}
    query_ids: set[str] = set()
    for wi, w in enumerate(raw_ws):
        c.wi, c.wid, c.qi, c.where = wi, None, None, None
        w = c.obj(w, "a workspace")
        wid = c.key(w, "id")
        if not isinstance(wid, str):
            c.fail(f"id must be a string, got {_got(wid)}")
        if not wid.strip():
            c.fail(f"id must be a non-empty string, got {wid!r}")
        c.wid = wid
        if wid in seen_ids:
            c.fail(f"duplicate workspace id {wid!r} (also workspace #{seen_ids[wid]}); ids must be unique")
        seen_ids[wid] = wi

        raw_obs = c.lst(c.key(w, "obstacles"), "obstacles")
        centers, sizes, primitives = [], [], []
        for oi, o in enumerate(raw_obs):
            c.where = f"obstacle #{oi}"
            o = c.obj(o, "an obstacle")
            center = c.vector(c.key(o, "center"), "center", spec.workspace_dim, "workspace dimension")
            size = c.vector(c.key(o, "size"), "size", spec.workspace_dim, "workspace dimension")
            for d, s in enumerate(size):
                if s <= 0:
                    c.fail(f"size[{d}] is {s:g}; box sizes must be positive")
            if "type" in o or "orientation" in o:
                if not posed:  # an @1 reader would take it for an axis-aligned box
                    c.fail(f"type and orientation need format {FORMAT_2!r}; this file is {FORMAT!r}")
                primitives.append(_primitive(c, o, center, size))
            else:
                centers.append(center)
                sizes.append(size)
        c.where = None

        raw_q = c.lst(c.key(w, "queries"), "queries")
        for qi, q in enumerate(raw_q):
            c.qi = qi
            q = c.obj(q, "a query")
            start = c.vector(c.key(q, "start"), "start", spec.state_dim, "state dimension")
            goal = c.vector(c.key(q, "goal"), "goal", spec.state_dim, "state dimension")
            ref = q.get("reference_cost")
            if ref is not None:
                ref = c.number(ref, "reference_cost")
                if ref <= 0:
                    c.fail(f"reference_cost is {ref:g}; it must be positive")
            qid = query_id(wid, qi)
            if posed and "id" in q:  # @2: a query may keep its own id (MotionBenchMaker's box_panda/0001)
                qid = q["id"]
                if not isinstance(qid, str) or not qid.strip():
                    c.fail(f"id must be a non-empty string, got {_got(qid)}")
                if qid in query_ids:
                    c.fail(f"duplicate query id {qid!r}; ids must be unique")
            query_ids.add(qid)
            queries.append(Query(id=qid, workspace_id=wid, split=SPLIT, start=start, goal=goal, reference_cost=ref))
        c.qi = None
        shape = (len(centers), spec.workspace_dim)  # an empty workspace keeps its dimension
        workspaces.append(
            Workspace(wid, SPLIT, np.reshape(centers, shape), np.reshape(sizes, shape), tuple(primitives))
        )

    c.wi = c.wid = c.qi = c.where = None
    try:
        _reject_leftover_non_finite(doc, c, raw_ws)
    except RecursionError:
        c.wi = c.wid = c.qi = c.where = None
        c.fail("nested too deeply")
    if not queries:
        c.fail("the file has no queries (every workspace's 'queries' list is empty)")
    return TestSet(spec=spec, workspaces=workspaces, queries=queries)


def _primitive(c: _Checker, o: dict, center: list, size: list) -> Primitive:
    """A posed obstacle of an @2 file (its center and size already checked)."""
    if not c.spec.robot.posed_obstacles:  # its checker would silently ignore them
        c.fail(f"posed obstacles (type, orientation) need an env whose checker handles them (arm7), not {c.spec.name}")
    kind = o.get("type", "box")
    if kind not in TYPES:
        c.fail(f"type is {_show(kind)}; expected one of {', '.join(TYPES)}")
    q = c.vector(o["orientation"], "orientation", 4, "a quaternion [x, y, z, w]") if "orientation" in o else IDENTITY
    if math.hypot(*q) < 1e-9:
        c.fail("orientation is a zero quaternion")
    if kind == "cylinder" and not math.isclose(size[0], size[1], rel_tol=1e-9):
        c.fail(f"a cylinder's size is [diameter, diameter, height], got {size}")
    if kind == "sphere" and not all(math.isclose(size[0], x, rel_tol=1e-9) for x in size):
        c.fail(f"a sphere's size is [diameter] * 3, got {size}")
    return Primitive(kind, center, size, q)


def _reject_leftover_non_finite(doc, c: _Checker, raw_ws: list) -> None:
    """NaN/Infinity anywhere, also under keys the loader otherwise ignores."""

    def walk(v, where: str):
        if isinstance(v, _NonFinite):
            c.where = where or None
            c.fail(f"{v.text} found; NaN and infinite numbers are not allowed anywhere in the file")
        if isinstance(v, dict):
            for k, x in v.items():
                walk(x, f"{where}.{k}" if where else k)
        elif isinstance(v, list):
            for i, x in enumerate(v):
                walk(x, f"{where}[{i}]")

    for k, v in doc.items():
        if k != "workspaces":
            walk(v, k)
    for wi, w in enumerate(raw_ws):
        c.wi, c.wid = wi, w["id"]
        for k, v in w.items():
            if k == "queries":
                for qi, q in enumerate(v):
                    c.qi = qi
                    walk(q, "")
                c.qi = None
            else:
                walk(v, k)
    c.wi = c.wid = c.qi = c.where = None


# --------------------------------------------------------------------------- API


def load_problems(path: str | Path, spec: EnvSpec) -> TestSet:
    """Read and validate a problem file for `spec` (the env chosen on the command line).

    Returns a TestSet whose workspaces and queries have split "file"; workspace ids are
    as given in the file, query ids are f"{workspace_id}/{index}" (an @2 query may give
    its own "id"). Raises
    ProblemFileError (one-line message naming the file, workspace and query) on any
    format problem; nothing is returned before the whole file has been checked.
    """
    return _check_document(_read_json(path), path, spec)


def problems_document(testset: TestSet, split: str | None = None) -> dict:
    """The JSON document `dump_problems` writes (queries grouped under their workspace,
    in the test set's order)."""
    spec = testset.spec
    wss = [w for w in testset.workspaces if split is None or w.split == split]
    if not wss:
        raise ValueError(
            "nothing to export: the test set has no workspaces" + (f" in split {split!r}" if split is not None else "")
        )
    out: list[dict] = []
    by_key: dict[tuple[str, str], list] = {}
    first_split: dict[str, str] = {}
    for w in wss:
        if w.id in first_split:
            raise ValueError(
                f"workspace id {w.id!r} appears in splits {first_split[w.id]!r} and {w.split!r}; "
                "problem-file ids must be unique, pass split= to export one split"
            )
        first_split[w.id] = w.split
        qs: list[dict] = []
        by_key[(w.id, w.split)] = qs
        out.append({"id": w.id, "obstacles": w.obstacles_json(), "queries": qs})
    for q in testset.queries:
        if split is not None and q.split != split:
            continue
        qs = by_key.get((q.workspace_id, q.split))
        if qs is None:
            raise ValueError(
                f"query {q.id!r} refers to workspace {q.workspace_id!r} in split {q.split!r}, "
                "which the test set does not hold"
            )
        item = {"start": [float(x) for x in q.start], "goal": [float(x) for x in q.goal]}
        if q.id != query_id(q.workspace_id, len(qs)):  # kept only where it is not the derived one (@2)
            item = {"id": q.id, **item}
        if q.reference_cost is not None:
            item["reference_cost"] = float(q.reference_cost)
        qs.append(item)
    posed = any(w.primitives for w in wss) or any("id" in q for w in out for q in w["queries"])
    return {"format": FORMAT_2 if posed else FORMAT, "env": spec.name, "workspaces": out}


def dumps_problems(doc: dict) -> str:
    """Pretty JSON text for a problem document: one line per obstacle and per query,
    so files with thousands of queries stay readable and diffable."""

    def render(v, depth: int) -> str:
        if depth >= 4 or not isinstance(v, (dict, list)) or not v:
            return json.dumps(v, allow_nan=False)
        pad, inner = " " * depth, " " * (depth + 1)
        if isinstance(v, dict):
            body = [f"{inner}{json.dumps(str(k))}: {render(x, depth + 1)}" for k, x in v.items()]
            return "{\n" + ",\n".join(body) + f"\n{pad}}}"
        body = [inner + render(x, depth + 1) for x in v]
        return "[\n" + ",\n".join(body) + f"\n{pad}]"

    return render(doc, 0) + "\n"


def dump_problems(path: str | Path, testset: TestSet, *, split: str | None = None) -> None:
    """Write `testset` (or one `split` of it) as a problem file that `load_problems`
    reads back to the same workspaces and queries (split "file", query ids re-derived
    from the position in the file). The document is validated with the loader's rules
    first, so a file that would not load is never written (ProblemFileError); the file
    is written to a temporary name and renamed into place."""
    doc = problems_document(testset, split)
    _check_document(doc, path, testset.spec)
    text = dumps_problems(doc)
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
