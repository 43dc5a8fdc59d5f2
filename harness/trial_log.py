"""Per-run trial log: `trials.mcap` (the record), `trials.rrd` (a Rerun recording) and
`queries.csv` (a flat table), written as queries finish (DESIGN §6, §8, §9).

Why it is shaped this way:
- The MCAP file is the record the report and `check_trials.py` read. Each query is
  flushed to the OS as its own zstd chunk, so a process killed at any point leaves a
  file that a stream reader reads up to the last finished query; `close()` (also run on
  exceptions, Ctrl-C and interpreter exit) finalises it so indexed readers open it too.
- Logging stays off the planner's timed section and costs tens of microseconds per
  query: JSON is encoded once, Rerun data is buffered and sent in columns (`send_columns`)
  every few dozen queries or seconds, and disk syncs (`fsync`) are rate-limited.
- `resume=True` re-reads what an earlier, possibly killed, run logged, re-writes it to a
  fresh file and exposes the finished (split, query_id) pairs in `done`, so a run never
  logs the same query twice.

The `/scene` topic carries Foxglove `foxglove.SceneUpdate` messages. Their schema,
`harness/schemas/foxglove.SceneUpdate.json`, is our own description of Foxglove's documented
SceneUpdate message, written from Foxglove's message-schema docs
(https://docs.foxglove.dev/docs/visualization/message-schemas/scene-update/ and the pages it
links); its field names are Foxglove's. Foxglove recognises the data by the schema name
`foxglove.SceneUpdate`. The file shares types through `$defs`; the copy written into the MCAP
file has every `$ref` inlined, since Foxglove's JSON Schema reader expects each field to give
its own `type`.
"""
from __future__ import annotations

import csv
import json
import math
import os
import time
import uuid
import warnings
import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

import numpy as np
from mcap.reader import make_reader
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from mpnet.envs.workspace import EnvSpec, Workspace

FORMAT = "mpnet-bench/trials@1"
MCAP_NAME = "trials.mcap"
RRD_NAME = "trials.rrd"
CSV_NAME = "queries.csv"
RESUME_SUFFIX = ".resume-"  # trials.mcap.resume-<k>: a previous file moved aside on resume
FRAME_ID = "world"
SCHEMA_DIR = Path(__file__).with_name("schemas")

# ---------------------------------------------------------------------------- schemas

RUN_FIELDS = ("env", "planner", "seed", "split", "config", "git_rev", "versions", "host", "started_at")
QUERY_FIELDS = ("query_id", "workspace_id", "split", "start", "goal", "success", "failure",
                "path", "time_s", "cpu_s", "path_cost", "collision_checks")
# Scalar columns of queries.csv that always come first, in this order.
CSV_FIXED = ("query_id", "workspace_id", "split", "success", "failure", "time_s", "cpu_s",
             "path_cost", "collision_checks")
_NON_CSV = frozenset(("start", "goal", "path"))

_NUM = {"type": "number"}
_VEC = {"type": "array", "items": _NUM}
_STATE_LIST = {"type": "array", "items": _VEC}

RUN_SCHEMA = {
    "$schema": "http://json-schema.org/draft-07/schema#",
    "title": "mpnet_bench.Run",
    "description": "One bench run: what was run, with which code and config (DESIGN §6).",
    "type": "object",
    "properties": {
        "format": {"type": "string", "description": "Log format version, e.g. " + FORMAT},
        "env": {"type": "string"},
        "planner": {"type": "string"},
        "seed": {"type": "integer"},
        "split": {"type": "string", "description": "seen, unseen, file or seen+unseen"},
        "config": {"type": "string", "description": "Resolved config as YAML text"},
        "git_rev": {"type": ["string", "null"]},
        "versions": {"type": "object", "description": "Package name to version"},
        "host": {"type": "string"},
        "started_at": {"type": ["string", "number"]},
        "resumed_from": {"type": "object", "description": "Set when the run resumed an earlier log"},
    },
    "required": list(RUN_FIELDS),
}
WORKSPACE_SCHEMA = {
    "$schema": "http://json-schema.org/draft-07/schema#",
    "title": "mpnet_bench.Workspace",
    "description": "A workspace used by the run: bounds, axis-aligned box obstacles, robot.",
    "type": "object",
    "properties": {
        "workspace_id": {"type": "string"},
        "split": {"type": "string", "description": "seen, unseen or file"},
        "bounds": {"type": "array", "items": {"type": "array", "items": _NUM, "minItems": 2, "maxItems": 2},
                   "description": "[lo, hi] per state dimension"},
        "obstacles": {"type": "array", "items": {
            "type": "object",
            "properties": {"center": _VEC, "size": _VEC},
            "required": ["center", "size"]}},
        "robot": {"type": ["object", "string"],
                  "description": '{"kind": "point"}, {"kind": "rectangle", "size": [w, h]} or the arm\'s name'},
    },
    "required": ["workspace_id", "split", "bounds", "obstacles", "robot"],
}
QUERY_SCHEMA = {
    "$schema": "http://json-schema.org/draft-07/schema#",
    "title": "mpnet_bench.Query",
    "description": "One finished query; extra keys are the planner's own statistics.",
    "type": "object",
    "properties": {
        "query_id": {"type": "string"},
        "workspace_id": {"type": "string"},
        "split": {"type": "string"},
        "start": _VEC,
        "goal": _VEC,
        "success": {"type": "boolean"},
        "failure": {"type": ["string", "null"], "description": "null on success, else the reason"},
        "path": _STATE_LIST,
        "time_s": {"type": ["number", "null"], "description": "Wall-clock planning time (null if not finite)"},
        "cpu_s": {"type": ["number", "null"]},
        "path_cost": {"type": ["number", "null"]},
        "collision_checks": {"type": ["integer", "null"]},
        "state_checks": {"type": ["integer", "null"]},
        "motion_checks": {"type": ["integer", "null"]},
        "pnet_calls": {"type": ["integer", "null"]},
        "replans": {"type": ["integer", "null"]},
        "fallback_used": {"type": ["boolean", "null"]},
        "planner_status": {"type": ["string", "null"]},
    },
    "required": list(QUERY_FIELDS),
}


def scene_update_schema(inline: bool = False) -> dict:
    """Our JSON Schema for Foxglove's foxglove.SceneUpdate (see module docstring).

    inline=True: every `$ref` replaced by its definition and `$defs` dropped, the form
    written to MCAP (Foxglove's reader does not follow `$ref`).
    """
    schema = json.loads((SCHEMA_DIR / "foxglove.SceneUpdate.json").read_text())
    return _inline_refs(schema, schema.get("$defs", {})) if inline else schema


def _inline_refs(node: Any, defs: dict) -> Any:
    """`node` with each {"$ref": "#/$defs/<name>", ...} replaced by that definition
    (recursively inlined, sibling keys kept) and any `$defs` dropped."""
    if isinstance(node, list):
        return [_inline_refs(x, defs) for x in node]
    if not isinstance(node, dict):
        return node
    out = {}
    ref = node.get("$ref")
    if ref is not None:
        prefix = "#/$defs/"
        if not ref.startswith(prefix) or ref[len(prefix):] not in defs:
            raise ValueError(f"unsupported $ref {ref!r}")
        out.update(_inline_refs(defs[ref[len(prefix):]], defs))
    for k, v in node.items():
        if k not in ("$ref", "$defs"):
            out[k] = _inline_refs(v, defs)
    return out


def _schema_bytes(schema: dict) -> bytes:
    return json.dumps(schema, separators=(",", ":")).encode()


# ------------------------------------------------------------------ plain Python values

def plain(v: Any) -> Any:
    """Numpy scalars/arrays, tuples and paths to plain JSON-ready Python values.

    JSON has no NaN or infinity: non-finite floats become None (null), so the file stays
    strict JSON that Foxglove and other parsers read.
    """
    t = type(v)
    if t is float:
        return v if math.isfinite(v) else None
    if t is str or t is int or t is bool or v is None:
        return v
    if t is list or t is tuple:
        return [plain(x) for x in v]
    if t is dict:
        return {str(k): plain(x) for k, x in v.items()}
    if isinstance(v, np.ndarray):
        if v.dtype.kind == "f" and not np.isfinite(v).all():
            return plain(v.tolist())
        return v.tolist()
    if isinstance(v, np.generic):
        return plain(v.item())
    if isinstance(v, bool):
        return bool(v)
    if isinstance(v, float):
        return plain(float(v))
    if isinstance(v, int):
        return int(v)
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, dict):
        return {str(k): plain(x) for k, x in v.items()}
    return str(v)  # enums, paths, ...: keep the information rather than fail the run


def _dumps(msg: dict) -> bytes:
    return json.dumps(msg, separators=(",", ":"), allow_nan=False).encode()


# --------------------------------------------------------------------------- reading

@dataclass
class LoggedMessage:
    topic: str
    data: dict
    log_time: int
    publish_time: int


def read_log(path: str | Path, topics: Iterable[str] | None = None) -> tuple[list[LoggedMessage], bool]:
    """All JSON messages of a trials.mcap, and whether the file was finalised.

    A file whose writer was killed has no summary; it is then read as a stream up to
    where it ends (as check_trials.py does), dropping a last, partly written record.
    """
    topics = None if topics is None else set(topics)
    try:
        with open(path, "rb") as f:
            out = [LoggedMessage(c.topic, json.loads(m.data), m.log_time, m.publish_time)
                   for _, c, m in make_reader(f).iter_messages(topics=topics, log_time_order=False)]
        return out, True
    except Exception:  # noqa: BLE001 - any failure means: not a finalised file
        pass
    out, chans = [], {}
    with open(path, "rb") as f:
        try:
            for rec in StreamReader(f, skip_magic=False).records:
                if isinstance(rec, Channel):
                    chans[rec.id] = rec.topic
                elif isinstance(rec, Message):
                    topic = chans.get(rec.channel_id)
                    if topic is None or (topics is not None and topic not in topics):
                        continue
                    try:
                        out.append(LoggedMessage(topic, json.loads(rec.data), rec.log_time, rec.publish_time))
                    except ValueError:
                        pass
        except Exception:  # noqa: BLE001 - truncated tail
            pass
    return out, False


# ------------------------------------------------------------------ scene geometry

_ID_QUAT = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
_ORIGIN_POSE = {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": _ID_QUAT}
_ZERO_DURATION = {"sec": 0, "nsec": 0}
THIN_Z = 0.1  # height of a 2D obstacle drawn as a cube; its top face is z = 0

C_OBSTACLE = (0.55, 0.55, 0.6, 0.85)
C_BOUNDS = (0.3, 0.3, 0.3, 1.0)
C_SUCCESS = (0.1, 0.75, 0.2, 1.0)
C_FAILURE = (0.9, 0.15, 0.1, 1.0)
C_START = (0.15, 0.35, 0.95, 1.0)
C_GOAL = (1.0, 0.6, 0.0, 1.0)
C_ROBOT = (0.35, 0.35, 0.35, 0.35)


def _rgba(c) -> dict:
    return {"r": c[0], "g": c[1], "b": c[2], "a": c[3]}


def _rgba8(c) -> tuple[int, int, int, int]:
    return tuple(int(round(255 * x)) for x in c)


def _stamp(ns: int) -> dict:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _p3(p) -> dict:
    return {"x": float(p[0]), "y": float(p[1]), "z": float(p[2]) if len(p) > 2 else 0.0}


def rect_outlines(states: np.ndarray, size) -> np.ndarray:
    """Closed outlines (n, 5, 2) of the rigid body's rectangle at each (x, y, theta).

    Body extents `size` = (along body x, along body y); body x axis is (cos, sin).
    """
    states = np.asarray(states, float).reshape(-1, 3)
    c, s = np.cos(states[:, 2]), np.sin(states[:, 2])
    hx, hy = size[0] / 2, size[1] / 2
    sx = np.array([-1, 1, 1, -1, -1], float) * hx  # corner loop, closed
    sy = np.array([-1, -1, 1, 1, -1], float) * hy
    x = states[:, :1] + sx[None] * c[:, None] - sy[None] * s[:, None]
    y = states[:, 1:2] + sx[None] * s[:, None] + sy[None] * c[:, None]
    return np.stack([x, y], axis=2)


def _box_edges(lo, hi) -> list[list[float]]:
    """Line-list points of an axis-aligned box's edges (2D rectangle or 3D box)."""
    if len(lo) == 2:
        c = [(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])]
        return [p for i in range(4) for p in (c[i], c[(i + 1) % 4])]
    pts = []
    for a in range(3):
        b, d = [k for k in range(3) if k != a]
        for vb in (lo[b], hi[b]):
            for vd in (lo[d], hi[d]):
                p, q = [0.0] * 3, [0.0] * 3
                p[a], q[a] = lo[a], hi[a]
                p[b] = q[b] = vb
                p[d] = q[d] = vd
                pts += [p, q]
    return pts


def _entity(eid: str, stamp: dict, **prims) -> dict:
    e = {"timestamp": stamp, "frame_id": FRAME_ID, "id": eid, "lifetime": _ZERO_DURATION,
         "frame_locked": False, "metadata": prims.pop("metadata", []), "arrows": [], "cubes": [],
         "spheres": [], "cylinders": [], "lines": [], "triangles": [], "texts": [], "models": []}
    e.update(prims)
    return e


def _line(kind: int, points: list, color, thickness: float) -> dict:
    return {"type": kind, "pose": _ORIGIN_POSE, "thickness": thickness, "scale_invariant": False,
            "points": [_p3(p) for p in points], "color": _rgba(color), "colors": [], "indices": []}


LINE_STRIP, LINE_LOOP, LINE_LIST = 0, 1, 2


# --------------------------------------------------------------------------- the log

class TrialLog:
    """One bench run's trial log; use as a context manager so it is always finalised.

    run: env, planner, seed, split, config (YAML text), git_rev, versions, host, started_at.
    extra_fields: optional planner-stat names to fix the order of queries.csv's columns.
    rerun_batch / rerun_every_s: how many queries, or how long, Rerun data is buffered.
    fsync_every_s: at most how often the MCAP file is synced to disk (0: after every query);
    a killed process loses nothing flushed, only a machine crash needs the sync.
    """

    def __init__(self, run_dir: str | Path, run: dict, spec: EnvSpec, *, rerun: bool = True,
                 resume: bool = False, extra_fields: Iterable[str] = (), rerun_batch: int = 64,
                 rerun_every_s: float = 2.0, fsync_every_s: float = 1.0):
        missing = [k for k in RUN_FIELDS if k not in run]
        if missing:
            raise ValueError(f"run is missing {', '.join(missing)}")
        self.run_dir = Path(run_dir)
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.spec = spec
        self.mcap_path = self.run_dir / MCAP_NAME
        self.rrd_path = self.run_dir / RRD_NAME if rerun else None
        self.csv_path = self.run_dir / CSV_NAME
        self.done: set[tuple[str, str]] = set()
        self._logged: set[tuple[str, str]] = set()
        self._workspaces: dict[tuple[str, str], dict] = {}
        self._scene_ws: tuple[str, str] | None = None
        self._n_queries = 0
        self._last_t = 0
        self._closed = False
        self._fsync_every = fsync_every_s
        self._last_sync = time.monotonic()
        self._trace_dim = spec.workspace_dim if (spec.is_se2 or spec.state_dim == spec.workspace_dim) else 0

        old, self._asides = self._take_previous(run, resume)
        run_msg = {"format": FORMAT, **plain(dict(run))}
        if old is not None:
            run_msg["resumed_from"] = {"files": [p.name for p in self._asides],
                                       "queries": sum(m.topic == "/query" for m in old)}

        scene_schema = _scene_schema_bytes()
        self._rr = _RerunSink(self.rrd_path, run, spec, rerun_batch, rerun_every_s) if rerun else None
        self._f = open(self.mcap_path, "wb")
        self._w = Writer(self._f, compression=CompressionType.ZSTD)
        self._csv = _QueryCsv(self.csv_path, extra_fields)
        # Interpreter exit without close() still finalises the files.
        self._finalizer = weakref.finalize(self, _finalize, self._w, self._f, self._csv, self._rr)
        self._w.start(profile="", library="mpnet-bench")
        ch = {}
        for topic, name, schema in (("/run", "mpnet_bench.Run", _schema_bytes(RUN_SCHEMA)),
                                    ("/workspace", "mpnet_bench.Workspace", _schema_bytes(WORKSPACE_SCHEMA)),
                                    ("/query", "mpnet_bench.Query", _schema_bytes(QUERY_SCHEMA)),
                                    ("/scene", "foxglove.SceneUpdate", scene_schema)):
            sid = self._w.register_schema(name, "jsonschema", schema)
            ch[topic] = self._w.register_channel(topic, "json", sid)
        self._ch = ch

        t = self._now()
        self._w.add_message(ch["/run"], t, _dumps(run_msg), t)
        if old is not None:
            self._replay(old)
        self._flush(force_sync=True)

    # ---------------------------------------------------------------- public API
    def add_workspace(self, ws: Workspace) -> None:
        """Log a workspace once per (split, id); later calls for the same key do nothing, and
        raise ValueError when its obstacles differ from the logged ones."""
        key = (str(ws.split), str(ws.id))
        obstacles = plain(ws.obstacles_json())
        if key in self._workspaces:
            if self._workspaces[key]["obstacles"] != obstacles:
                raise ValueError(f"workspace {key[1]!r} of split {key[0]!r} is already logged with other "
                                 f"obstacles; a resumed run must plan the same workspaces")
            return
        self._check_open()
        msg = {"workspace_id": key[1], "split": key[0], "bounds": self.spec.bounds_json(),
               "obstacles": obstacles, "robot": self.spec.robot_json()}
        self._emit_workspace(msg, self._now())
        self._flush()

    def add_query(self, rec: dict) -> None:
        """Log one finished query; on return it is on disk (flushed to the OS)."""
        self._check_open()
        missing = [k for k in QUERY_FIELDS if k not in rec]
        if missing:
            raise ValueError(f"query record is missing {', '.join(missing)}")
        msg = {k: plain(v) for k, v in rec.items()}
        msg["query_id"] = str(msg["query_id"])
        msg["workspace_id"] = str(msg["workspace_id"])
        msg["split"] = str(msg["split"])
        key = (msg["split"], msg["query_id"])
        if key in self._logged:
            raise ValueError(f"query {key[1]!r} of split {key[0]!r} is already logged")
        if (msg["split"], msg["workspace_id"]) not in self._workspaces:
            raise ValueError(f"query {key[1]!r}: workspace {msg['workspace_id']!r} of split "
                             f"{msg['split']!r} was not added (add_workspace first)")
        self._emit_query(msg, self._now())
        self._flush()

    def close(self) -> None:
        """Finalise the MCAP file, the recording and the CSV; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self._finalizer.detach()
        ok = _finalize(self._w, self._f, self._csv, self._rr)
        if ok:
            for p in self._asides:  # their messages now live in the finalised file
                try:
                    p.unlink()
                except OSError:
                    pass

    def __enter__(self) -> "TrialLog":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def logged_obstacles(self) -> dict[tuple[str, str], list]:
        """(split, workspace_id) -> obstacles of every workspace in the log (resume checks)."""
        return {k: m["obstacles"] for k, m in self._workspaces.items()}

    @property
    def n_queries(self) -> int:
        return self._n_queries

    # ---------------------------------------------------------------- internals
    def _check_open(self):
        if self._closed:
            raise ValueError("trial log is closed")

    def _now(self) -> int:
        """Wall-clock ns, strictly increasing so log-time order is logging order."""
        t = max(time.time_ns(), self._last_t + 1)
        self._last_t = t
        return t

    def _flush(self, force_sync: bool = False):
        self._w.flush()  # closes the chunk, writes it, flushes the Python buffer to the OS
        now = time.monotonic()
        if force_sync or now - self._last_sync >= self._fsync_every:
            os.fsync(self._f.fileno())
            self._last_sync = now

    def _take_previous(self, run: dict, resume: bool):
        """On resume, read the previous file(s) and move them aside; None when starting fresh."""
        asides = sorted(self.run_dir.glob(MCAP_NAME + RESUME_SUFFIX + "*"), key=_aside_index)
        if not resume:
            if self.mcap_path.exists() or asides:
                raise FileExistsError(f"{self.mcap_path} exists; pass resume=True to continue that run")
            return None, []
        sources = asides + ([self.mcap_path] if self.mcap_path.exists() else [])
        if not sources:
            return None, []
        old: list[LoggedMessage] = []
        for p in sources:
            msgs, _ = read_log(p, ["/run", "/workspace", "/query"])
            for m in msgs:
                if m.topic == "/run":
                    for k in ("env", "planner", "seed"):
                        if k in m.data and plain(run[k]) != m.data[k]:
                            raise ValueError(f"cannot resume {p}: it logged {k}={m.data[k]!r}, "
                                             f"this run has {run[k]!r}")
            old += msgs
        if self.mcap_path.exists():
            k = 1 + max(map(_aside_index, asides), default=0)
            aside = self.mcap_path.with_name(MCAP_NAME + RESUME_SUFFIX + str(k))
            os.replace(self.mcap_path, aside)
            asides.append(aside)
        return old, asides

    def _replay(self, old: list[LoggedMessage]):
        """Re-write an earlier log's workspaces and queries with their original times."""
        old = sorted((m for m in old if m.topic in ("/workspace", "/query")), key=lambda m: m.log_time)
        orphans = 0
        for m in old:
            d = {**m.data, "split": str(m.data.get("split")), "workspace_id": str(m.data.get("workspace_id"))}
            if m.topic == "/workspace":
                if (d["split"], d["workspace_id"]) not in self._workspaces:
                    self._emit_workspace(d, m.log_time)
            else:
                d["query_id"] = str(d.get("query_id"))
                key = (d["split"], d["query_id"])
                if key in self._logged:
                    continue
                if (d["split"], d["workspace_id"]) not in self._workspaces:
                    orphans += 1
                    continue
                self._emit_query(d, m.log_time)
                self.done.add(key)
            self._last_t = max(self._last_t, m.log_time)
        self._last_t = max(self._last_t, time.time_ns())
        if orphans:
            warnings.warn(f"trial log: {orphans} earlier queries had no /workspace message; "
                          "they will be planned again", RuntimeWarning, stacklevel=3)

    def _emit_workspace(self, msg: dict, t: int):
        key = (msg["split"], msg["workspace_id"])
        self._workspaces[key] = msg
        self._w.add_message(self._ch["/workspace"], t, _dumps(msg), t)
        if self._rr is not None:
            self._rr.workspace(msg)

    def _emit_ws_scene(self, key, t: int):
        """Clear the Foxglove scene and draw this workspace, so paths show on their own
        obstacles. Drawn when its first query is logged (workspaces may all be added up
        front), and again only if queries switch back to it."""
        msg = self._workspaces[key]
        stamp = _stamp(t)
        wd = self.spec.workspace_dim
        cubes = []
        for o in msg["obstacles"]:
            c, s = o["center"], o["size"]
            if wd == 2:
                pos = {"x": c[0], "y": c[1], "z": -THIN_Z / 2}
                size = {"x": s[0], "y": s[1], "z": THIN_Z}
            else:
                pos, size = _p3(c), _p3(s)
            cubes.append({"pose": {"position": pos, "orientation": _ID_QUAT}, "size": size,
                          "color": _rgba(C_OBSTACLE)})
        b = msg["bounds"][:wd]
        lines = [_line(LINE_LIST, _box_edges([x[0] for x in b], [x[1] for x in b]), C_BOUNDS, 0.1)]
        ent = _entity(f"workspace/{key[0]}/{key[1]}", stamp, cubes=cubes, lines=lines,
                      metadata=[{"key": "workspace_id", "value": key[1]}, {"key": "split", "value": key[0]}])
        upd = {"deletions": [{"timestamp": stamp, "type": 1, "id": ""}], "entities": [ent]}
        self._w.add_message(self._ch["/scene"], t, _dumps(upd), t)
        self._scene_ws = key

    def _emit_query(self, msg: dict, t: int):
        key = (msg["split"], msg["query_id"])
        ws_key = (msg["split"], msg["workspace_id"])
        data = _dumps(msg)
        self._w.add_message(self._ch["/query"], t, data, t)
        if ws_key != self._scene_ws:
            self._emit_ws_scene(ws_key, t)
        self._w.add_message(self._ch["/scene"], t, self._query_scene(msg, t), t)
        self._logged.add(key)
        self._csv.add(msg)
        if self._rr is not None:
            self._rr.query(self._n_queries, msg, self._workspaces[ws_key])
        self._n_queries += 1

    def _trace(self, msg: dict):
        """Workspace-space points of the path, start and goal (centre for the rigid body)."""
        d = self._trace_dim
        if not d:
            ee = msg.get("ee_path")
            return (ee or []), (ee[0] if ee else None), (ee[-1] if ee else None)
        return [p[:d] for p in (msg.get("path") or [])], msg["start"][:d], msg["goal"][:d]

    def _query_scene(self, msg: dict, t: int) -> bytes:
        """The query's foxglove.SceneUpdate as JSON: path as a line strip, start and goal
        as spheres, and for the rigid body its footprint (a thin box) at each state.

        Encoded from string templates because it is on the per-query path and
        json.dumps of these nested dicts costs ~50 us; tests validate the output
        against the foxglove.SceneUpdate schema.
        """
        ok = bool(msg.get("success"))
        trace, start, goal = self._trace(msg)
        pts = ",".join([_P3 % (_fx(p[0]), _fx(p[1]), _fx(p[2]) if len(p) > 2 else "0.0") for p in trace])
        spheres = ",".join([_SPHERE % (_fx(p[0]), _fx(p[1]), _fx(p[2]) if len(p) > 2 else "0.0", c)
                            for p, c in ((start, _J_START), (goal, _J_GOAL)) if p is not None])
        cubes = ""
        if self.spec.is_se2:
            states = msg.get("path") or [msg["start"], msg["goal"]]
            sx, sy = self.spec.robot_size[0], self.spec.robot_size[1]
            cubes = ",".join([_FOOTPRINT % (_fx(q[0]), _fx(q[1]), repr(math.sin(_f(q[2]) / 2)),
                                            repr(math.cos(_f(q[2]) / 2)), sx, sy) for q in states])
        meta = json.dumps([{"key": k, "value": str(msg.get(k))} for k in _SCENE_META], separators=(",", ":"))
        ent = _ENTITY % (t // 1_000_000_000, t % 1_000_000_000,
                         json.dumps(f"query/{msg['split']}/{msg['query_id']}"), meta, cubes, spheres,
                         _STRIP % (pts, _J_SUCCESS if ok else _J_FAILURE))
        return ('{"deletions":[],"entities":[%s]}' % ent).encode()


def _f(x) -> float:
    return 0.0 if x is None else float(x)


def _fx(x) -> str:
    """JSON text of a plain number (None, from a non-finite value, draws at 0)."""
    return "0.0" if x is None else repr(x)


def _jcolor(c) -> str:
    return json.dumps(_rgba(c), separators=(",", ":"))


_J_SUCCESS, _J_FAILURE, _J_START, _J_GOAL, _J_ROBOT = map(_jcolor, (C_SUCCESS, C_FAILURE, C_START, C_GOAL, C_ROBOT))
_J_ID_QUAT = json.dumps(_ID_QUAT, separators=(",", ":"))
_P3 = '{"x":%s,"y":%s,"z":%s}'
_SPHERE = ('{"pose":{"position":' + _P3 + ',"orientation":' + _J_ID_QUAT
           + '},"size":{"x":0.8,"y":0.8,"z":0.8},"color":%s}')
_FOOTPRINT = ('{"pose":{"position":{"x":%s,"y":%s,"z":0.01},"orientation":{"x":0.0,"y":0.0,"z":%s,"w":%s}},'
              '"size":{"x":%r,"y":%r,"z":0.02},"color":' + _J_ROBOT + '}')
_STRIP = ('{"type":0,"pose":' + json.dumps(_ORIGIN_POSE, separators=(",", ":"))
          + ',"thickness":0.15,"scale_invariant":false,"points":[%s],"color":%s,"colors":[],"indices":[]}')
_ENTITY = ('{"timestamp":{"sec":%d,"nsec":%d},"frame_id":"' + FRAME_ID + '","id":%s,'
           '"lifetime":{"sec":0,"nsec":0},"frame_locked":false,"metadata":%s,"arrows":[],"cubes":[%s],'
           '"spheres":[%s],"cylinders":[],"lines":[%s],"triangles":[],"texts":[],"models":[]}')
_SCENE_META = ("query_id", "workspace_id", "success", "failure", "time_s", "path_cost", "collision_checks")


def _aside_index(p: Path) -> int:
    """k of trials.mcap.resume-<k> (files are re-read oldest first)."""
    tail = p.name.rsplit("-", 1)[-1]
    return int(tail) if tail.isdigit() else 0


_SCENE_SCHEMA_CACHE: list[bytes] = []


def _scene_schema_bytes() -> bytes:
    if not _SCENE_SCHEMA_CACHE:
        _SCENE_SCHEMA_CACHE.append(_schema_bytes(scene_update_schema(inline=True)))
    return _SCENE_SCHEMA_CACHE[0]


def _finalize(writer, f, csv_sink, rr_sink) -> bool:
    """Close every sink, each even if another fails; True if the MCAP file was finalised."""
    ok = False
    try:
        if rr_sink is not None:
            rr_sink.close()
    except Exception as e:  # noqa: BLE001
        warnings.warn(f"trial log: could not finish the Rerun recording: {e!r}", RuntimeWarning, stacklevel=2)
    try:
        writer.finish()
        f.flush()
        os.fsync(f.fileno())
        ok = True
    except Exception as e:  # noqa: BLE001
        warnings.warn(f"trial log: could not finalise trials.mcap: {e!r}", RuntimeWarning, stacklevel=2)
    finally:
        try:
            f.close()
        except Exception:  # noqa: BLE001
            pass
        csv_sink.close()
    return ok


# --------------------------------------------------------------------------- CSV

class _QueryCsv:
    """queries.csv: the scalar fields of each query, one row each, flushed per row.

    Columns are the fixed fields, then `extra_fields`, then other scalar keys in the order
    first seen; a key first seen late rewrites the file (atomically) with the wider header.
    """

    def __init__(self, path: Path, extra_fields: Iterable[str]):
        self.path = path
        self.cols = list(CSV_FIXED) + [k for k in extra_fields if k not in CSV_FIXED]
        self._known = set(self.cols)
        self.rows: list[dict] = []
        self._open(rewrite=False)

    def _open(self, rewrite: bool):
        tmp = self.path.with_name(self.path.name + ".tmp")
        f = open(tmp if rewrite else self.path, "w", newline="", encoding="utf-8")
        w = csv.DictWriter(f, self.cols, restval="", extrasaction="ignore")
        w.writeheader()
        if rewrite:
            w.writerows(self.rows)
            f.flush()
            os.replace(tmp, self.path)
        self.f, self.w = f, w
        f.flush()

    def add(self, msg: dict):
        row = {k: v for k, v in msg.items() if k not in _NON_CSV and (v is None or type(v) in (str, int, float, bool))}
        new = [k for k in row if k not in self._known]
        self.rows.append(row)
        if new:
            self.cols += new
            self._known.update(new)
            old = self.f
            self._open(rewrite=True)
            old.close()
        else:
            self.w.writerow(row)
            self.f.flush()

    def close(self):
        try:
            self.f.close()
        except Exception:  # noqa: BLE001
            pass


# --------------------------------------------------------------------------- Rerun

class _RerunSink:
    """trials.rrd: obstacles as boxes, each query's path, start and goal on the `query`
    timeline, and time/collision-check plots. Queries are buffered and sent as columns,
    which costs a few microseconds per query instead of ~0.2 ms per query with rr.log."""

    def __init__(self, path: Path, run: dict, spec: EnvSpec, batch: int, every_s: float):
        import rerun as rr
        import rerun.blueprint as rrb

        self.rr = rr
        self.spec = spec
        self.wd = spec.workspace_dim
        self.trace_dim = spec.workspace_dim if (spec.is_se2 or spec.state_dim == spec.workspace_dim) else 0
        self.batch, self.every_s = max(1, int(batch)), every_s
        self.pending: list[tuple[int, dict, dict]] = []
        self.last_send = time.monotonic()
        self.shown_ws: tuple[str, str] | None = None
        rid = uuid.uuid5(uuid.NAMESPACE_URL, "mpnet-bench:" + str(path.resolve().parent))
        self.rec = rr.RecordingStream("mpnet_bench", recording_id=rid)
        self.rec.save(path, default_blueprint=self._blueprint(rrb))
        self.rec.send_recording_name(f"{run.get('env')} {run.get('planner')} seed {run.get('seed')}")
        two_d = self.wd == 2
        self.Boxes = rr.Boxes2D if two_d else rr.Boxes3D
        self.Strips = rr.LineStrips2D if two_d else rr.LineStrips3D
        self.Points = rr.Points2D if two_d else rr.Points3D
        lo, hi = spec.lower[: self.wd], spec.upper[: self.wd]
        if two_d:
            # Rerun's 2D views draw y down; flip the world so y points up as in the paper.
            self.rec.log("scene/world", rr.Transform3D(scale=[1.0, -1.0, 1.0]), static=True)
            self.rec.log("scene/world/bounds", rr.LineStrips2D([[lo, [hi[0], lo[1]], hi, [lo[0], hi[1]], lo]],
                                                               colors=[_rgba8(C_BOUNDS)]), static=True)
        elif self.wd == 3:
            self.rec.log("scene/world/bounds", rr.Boxes3D(mins=[lo], sizes=[hi - lo], colors=[_rgba8(C_BOUNDS)]),
                         static=True)

    def _blueprint(self, rrb):
        if self.wd == 2:
            lo, hi = self.spec.lower[:2], self.spec.upper[:2]
            pad = 0.05 * float(max(hi - lo))
            scene = rrb.Spatial2DView(name="scene", origin="/scene", visual_bounds=rrb.VisualBounds2D(
                x_range=[lo[0] - pad, hi[0] + pad], y_range=[-hi[1] - pad, -lo[1] + pad]))
        else:
            scene = rrb.Spatial3DView(name="scene", origin="/scene")
        plots = rrb.Vertical(rrb.TimeSeriesView(name="planning time [s]", origin="/stats/time_s"),
                             rrb.TimeSeriesView(name="collision checks", origin="/stats/collision_checks"))
        return rrb.Blueprint(rrb.Horizontal(scene, plots, column_shares=[2, 1]),
                             rrb.TimePanel(timeline="query"), collapse_panels=True)

    def _boxes(self, ws_msg: dict):
        obs = ws_msg["obstacles"]
        c = np.array([o["center"][: self.wd] for o in obs], float).reshape(-1, self.wd)
        s = np.array([o["size"][: self.wd] for o in obs], float).reshape(-1, self.wd)
        return self.Boxes(centers=c, sizes=s, colors=[_rgba8(C_OBSTACLE)])

    def workspace(self, ws_msg: dict):
        if not self.wd:
            return
        self.rec.log(["workspaces", ws_msg["split"], ws_msg["workspace_id"], "obstacles"],
                     self._boxes(ws_msg), static=True)

    def query(self, i: int, msg: dict, ws_msg: dict):
        self.pending.append((i, msg, ws_msg))
        if len(self.pending) >= self.batch or time.monotonic() - self.last_send >= self.every_s:
            self.send()

    def send(self):
        """Send the buffered queries; a failure costs the recording these rows, never the run."""
        if not self.pending:
            return
        items, self.pending = self.pending, []
        self.last_send = time.monotonic()
        try:
            self._send(items)
        except Exception as e:  # noqa: BLE001 - the MCAP file is the record, the rrd a view of it
            warnings.warn(f"trial log: {len(items)} queries missing from trials.rrd: {e!r}",
                          RuntimeWarning, stacklevel=3)

    def _send(self, items):
        """Columns, one row per query on the `query` timeline."""
        rr, rec = self.rr, self.rec
        for i, msg, ws in items:  # obstacles of the workspace on screen, when it changes
            key = (ws["split"], ws["workspace_id"])
            if key != self.shown_ws and self.wd:
                rec.set_time("query", sequence=i)
                rec.log("scene/world/obstacles", self._boxes(ws))
                self.shown_ws = key
        idx = [rr.TimeColumn("query", sequence=[i for i, _, _ in items])]
        n = len(items)
        ok = np.array([bool(m.get("success")) for _, m, _ in items])
        rec.send_columns("stats/time_s", indexes=idx, columns=rr.Scalars.columns(
            scalars=np.array([_num(m.get("time_s")) for _, m, _ in items], float)))
        rec.send_columns("stats/collision_checks", indexes=idx, columns=rr.Scalars.columns(
            scalars=np.array([_num(m.get("collision_checks")) for _, m, _ in items], float)))
        d = self.trace_dim
        if not d:
            return
        colors = np.where(ok[:, None], np.array(_rgba8(C_SUCCESS), np.uint8), np.array(_rgba8(C_FAILURE), np.uint8))
        strips = [np.asarray(m.get("path") or np.zeros((0, d)), float).reshape(-1, _state_dim(m, d))[:, :d]
                  for _, m, _ in items]
        labels = [f"{m['query_id']}: " + ("ok" if m.get("success") else str(m.get("failure"))) for _, m, _ in items]
        rec.send_columns("scene/world/path", indexes=idx, columns=self.Strips.columns(
            strips=strips, colors=colors, labels=labels))
        ends = np.array([[m["start"][:d], m["goal"][:d]] for _, m, _ in items], float).reshape(2 * n, d)
        end_colors = np.tile(np.array([_rgba8(C_START), _rgba8(C_GOAL)], np.uint8), (n, 1))
        rec.send_columns("scene/world/endpoints", indexes=idx, columns=self.Points.columns(
            positions=ends, colors=end_colors, radii=np.full(2 * n, 0.4, np.float32)).partition([2] * n))
        if self.spec.is_se2:
            outl, lens = [], []
            for _, m, _ in items:
                st = m.get("path") or [m["start"], m["goal"]]
                o = rect_outlines(np.asarray(st, float), self.spec.robot_size)
                outl.append(o)
                lens.append(len(o))
            outl = np.concatenate(outl)
            rec.send_columns("scene/world/robot", indexes=idx, columns=rr.LineStrips2D.columns(
                strips=outl, colors=np.tile(np.array(_rgba8(C_ROBOT), np.uint8), (len(outl), 1))).partition(lens))

    def close(self):
        try:
            self.send()
        finally:
            self.rec.flush()
            self.rec.disconnect()


def _state_dim(m: dict, d: int) -> int:
    """State dimension of a query's path (start's length), at least the trace dimension."""
    return max(len(m["start"]), d)


def _num(v) -> float:
    return float("nan") if v is None else float(v)
