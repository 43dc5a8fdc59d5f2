"""Per-run trial log: `trials.mcap` (the record), `trials.rrd` (a Rerun recording) and
`queries.csv` (a flat table), written as queries finish (docs/reports.md, docs/reliability.md).

Why it is shaped this way:
- The MCAP file is the record the report and `check_trials.py` read. Each query is
  flushed to the OS as its own zstd chunk, so a process killed at any point leaves a
  file that a stream reader reads up to the last finished query; `close()` (also run on
  exceptions, Ctrl-C and interpreter exit) finalises it so indexed readers open it too.
- Logging stays off the planner's timed section and costs tens of microseconds per
  query: JSON is encoded once, Rerun data is buffered and sent in columns (`send_columns`)
  every few dozen queries or seconds, and disk syncs (`fsync`) are rate-limited.
- `resume=True` re-reads what an earlier, possibly killed or damaged, run logged, re-writes
  it to a fresh file and exposes the finished (split, query_id) pairs in `done`, so a run
  never logs the same query twice. It is refused (ResumeRefused) when the earlier run had
  other settings (`run["settings"]`), and a damaged earlier file is never overwritten: its
  readable messages are kept and the file is moved aside (`notes` says where).
- What the scenes show of the robot is the painter's (harness.log.painters), chosen from
  the robot JSON this log writes to /workspace.
"""

from __future__ import annotations

import atexit
import os
import time
import warnings
import weakref
from collections.abc import Iterable
from pathlib import Path

from harness.log.csv import CSV_NAME, QueryCsv
from harness.log.foxglove import query_scene, workspace_scene
from harness.log.mcap_io import (
    MCAP_NAME,
    RESUME_SUFFIX,
    LoggedMessage,
    aside_index,
    dumps,
    keep_damaged,
    new_writer,
    plain,
    start_channels,
)
from harness.log.painters import painter_for
from harness.log.recover import scan_log
from harness.log.rerun import RRD_NAME, RerunSink
from harness.log.schemas import FORMAT, QUERY_FIELDS, RUN_FIELDS, run_segments, topic_schemas


class ResumeRefused(ValueError):
    """resume=true over a log that this run cannot continue (one line for the user)."""


class TrialLog:
    """One bench run's trial log; use as a context manager so it is always finalised.

    run: env, planner, seed, split, config (YAML text), git_rev, versions, host, started_at.
    spec: the env's spec (name, state_dim, workspace_dim, robot_json(), bounds_json()).
    extra_fields: optional planner-stat names to fix the order of queries.csv's columns.
    rerun_batch / rerun_every_s: how many queries, or how long, Rerun data is buffered.
    fsync_every_s: at most how often the MCAP file is synced to disk (0: after every query);
    a killed process loses nothing flushed, only a machine crash needs the sync.
    """

    def __init__(
        self,
        run_dir: str | Path,
        run: dict,
        spec,
        *,
        rerun: bool = True,
        resume: bool = False,
        extra_fields: Iterable[str] = (),
        rerun_batch: int = 64,
        rerun_every_s: float = 2.0,
        fsync_every_s: float = 1.0,
    ):
        missing = [k for k in RUN_FIELDS if k not in run]
        if missing:
            raise ValueError(f"run is missing {', '.join(missing)}")
        self.run_dir = Path(run_dir)
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.spec = spec
        self.robot = plain(spec.robot_json())
        self.bounds = plain(spec.bounds_json())
        self.painter = painter_for(self.robot, spec.workspace_dim)
        self.planner = str(run["planner"])  # in every scene label
        self.mcap_path = self.run_dir / MCAP_NAME
        self.rrd_path = self.run_dir / RRD_NAME if rerun else None
        self.csv_path = self.run_dir / CSV_NAME
        self.done: set[tuple[str, str]] = set()
        self.notes: list[str] = []  # what resume did with earlier files, for the user
        self._logged: set[tuple[str, str]] = set()
        self._workspaces: dict[tuple[str, str], dict] = {}
        self._scene_ws: tuple[str, str] | None = None
        self._n_queries = 0
        self._last_t = 0
        self._closed = False
        self._fsync_every = fsync_every_s
        self._last_sync = time.monotonic()

        old, self._asides = self._take_previous(run, resume)
        run_msg = {"format": FORMAT, **plain(dict(run))}
        if old is not None:
            earlier = [seg for m in old if m.topic == "/run" for seg in run_segments(m.data)]
            run_msg["resumed_from"] = {
                "files": [p.name for p in self._asides],
                "queries": sum(m.topic == "/query" for m in old),
                "runs": [dict(t) for t in dict.fromkeys(tuple(s.items()) for s in earlier)],
            }

        topics = topic_schemas()  # read before any file is opened: a bad schema file fails here
        self._rr = (
            RerunSink(self.rrd_path, run, self.painter, self.bounds, rerun_batch, rerun_every_s) if rerun else None
        )
        self._f = open(self.mcap_path, "wb")
        self._w = new_writer(self._f)
        self._csv = QueryCsv(self.csv_path, extra_fields)
        # Interpreter exit without close() still finalises the files, before Rerun's own exit
        # handler closes its recording: weakref.finalize's exit hook runs in the order its
        # first use registered it (any import may have used it before rerun was imported), so
        # the finalizer is also registered with atexit here, after rerun, to run before it.
        self._finalizer = weakref.finalize(self, _finalize, self._w, self._f, self._csv, self._rr)
        atexit.register(self._finalizer)
        self._ch = start_channels(self._w, topics)

        t = self._now()
        self._w.add_message(self._ch["/run"], t, dumps(run_msg), t)
        if old is not None:
            self._replay(old)
        self._flush(force_sync=True)

    # ---------------------------------------------------------------- public API
    def add_workspace(self, ws) -> None:
        """Log a workspace (id, split, obstacles_json()) once per (split, id); later calls for
        the same key do nothing, and raise ValueError when its obstacles differ from the
        logged ones."""
        key = (str(ws.split), str(ws.id))
        obstacles = plain(ws.obstacles_json())
        if key in self._workspaces:
            if self._workspaces[key]["obstacles"] != obstacles:
                raise ValueError(
                    f"workspace {key[1]!r} of split {key[0]!r} is already logged with other "
                    f"obstacles; a resumed run must plan the same workspaces"
                )
            return
        self._check_open()
        msg = {
            "workspace_id": key[1],
            "split": key[0],
            "bounds": self.spec.bounds_json(),
            "obstacles": obstacles,
            "robot": self.spec.robot_json(),
        }
        self._emit_workspace(msg, self._now())
        self._flush()

    def add_query(self, rec: dict, flush: bool = True) -> None:
        """Log one finished query; on return it is on disk (flushed to the OS), unless
        flush=False: then it waits in the open chunk for flush() (batches of queries)."""
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
            raise ValueError(
                f"query {key[1]!r}: workspace {msg['workspace_id']!r} of split "
                f"{msg['split']!r} was not added (add_workspace first)"
            )
        self._emit_query(msg, self._now())
        if flush:
            self._flush()

    def flush(self) -> None:
        """Write the open chunk (the queries added with flush=False) to the OS."""
        self._check_open()
        self._flush()

    def close(self) -> None:
        """Finalise the MCAP file, the recording and the CSV; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        atexit.unregister(self._finalizer)
        self._finalizer.detach()
        ok = _finalize(self._w, self._f, self._csv, self._rr)
        if ok:
            for p in self._asides:  # their messages now live in the finalised file
                try:
                    p.unlink()
                except OSError:
                    pass

    def __enter__(self) -> TrialLog:
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
        asides = sorted(self.run_dir.glob(MCAP_NAME + RESUME_SUFFIX + "*"), key=aside_index)
        if not resume:
            if self.mcap_path.exists() or asides:
                raise FileExistsError(f"{self.mcap_path} exists; pass resume=True to continue that run")
            return None, []
        sources = asides + ([self.mcap_path] if self.mcap_path.exists() else [])
        old: list[LoggedMessage] = []
        damaged: list[tuple[Path, str]] = []
        for p in sources:
            scan = scan_log(p, ["/run", "/workspace", "/query"])
            msgs = [LoggedMessage(*m) for m in scan.messages]
            runs = [m.data for m in msgs if m.topic == "/run"]
            queries = sum(m.topic == "/query" for m in msgs)
            if not runs and queries:
                raise ResumeRefused(
                    f"cannot resume {p}: its /run message is unreadable ({scan.describe_damage()}), so its "
                    f"settings cannot be checked; move it away or choose another run dir"
                )
            for old_run in runs:
                _check_same_run(p, old_run, run)
            if not runs and scan.size:
                damaged.append((p, f"{p.name} holds no readable trial (not a trial log, or damaged throughout)"))
            elif scan.damaged:
                damaged.append(
                    (p, f"{p.name} is damaged ({scan.describe_damage()}): its {queries} readable queries are kept")
                )
            old += msgs
        for p, note in damaged:  # never overwritten or deleted: kept under a name of its own
            self.notes.append(f"{note}; the file is kept as {keep_damaged(p)}")
            if p in asides:
                asides.remove(p)
        if self.mcap_path.exists():
            k = 1 + max(map(aside_index, asides), default=0)
            aside = self.mcap_path.with_name(MCAP_NAME + RESUME_SUFFIX + str(k))
            os.replace(self.mcap_path, aside)
            asides.append(aside)
        return (old if sources else None), asides

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
            warnings.warn(
                f"trial log: {orphans} earlier queries had no /workspace message; they will be planned again",
                RuntimeWarning,
                stacklevel=3,
            )

    def _emit_workspace(self, msg: dict, t: int):
        key = (msg["split"], msg["workspace_id"])
        self._workspaces[key] = msg
        self._w.add_message(self._ch["/workspace"], t, dumps(msg), t)
        if self._rr is not None:
            self._rr.workspace(msg)

    def _emit_query(self, msg: dict, t: int):
        key = (msg["split"], msg["query_id"])
        ws_key = (msg["split"], msg["workspace_id"])
        self._w.add_message(self._ch["/query"], t, dumps(msg), t)
        if ws_key != self._scene_ws:
            # Clear the Foxglove scene and draw this workspace, so paths show on their own
            # obstacles: when its first query is logged (workspaces may all be added up
            # front), and again only if queries switch back to it.
            self._w.add_message(self._ch["/scene"], t, workspace_scene(self.painter, self._workspaces[ws_key], t), t)
            self._scene_ws = ws_key
        self._w.add_message(self._ch["/scene"], t, query_scene(self.painter, msg, t, self.planner), t)
        self._logged.add(key)
        self._csv.add(msg)
        if self._rr is not None:
            self._rr.query(self._n_queries, msg, self._workspaces[ws_key])
        self._n_queries += 1


def _check_same_run(path: Path, old: dict, new: dict) -> None:
    """ResumeRefused unless the earlier run had this run's env, planner, seed and settings."""
    for k in ("env", "planner", "seed"):
        if k in old and plain(new[k]) != old[k]:
            raise ResumeRefused(f"cannot resume {path}: it logged {k}={old[k]!r}, this run has {new[k]!r}")
    if "settings" not in new:
        return
    if "settings" not in old:
        raise ResumeRefused(
            f"cannot resume {path}: it was written without its settings (an older mpnet-bench), so they "
            f"cannot be checked; choose another run dir"
        )
    before, now = old["settings"], plain(new["settings"])
    missing = object()
    diffs = [
        f"{k} ({'unset' if before.get(k, missing) is missing else repr(before[k])} -> "
        f"{'unset' if now.get(k, missing) is missing else repr(now[k])})"
        for k in sorted(set(before) | set(now))
        if before.get(k, missing) != now.get(k, missing)
    ]
    if diffs:
        shown = ", ".join(diffs[:4]) + (f" and {len(diffs) - 4} more" if len(diffs) > 4 else "")
        raise ResumeRefused(
            f"cannot resume {path}: it was run with other settings: {shown}; resume with the same "
            f"settings or choose another hydra.run.dir"
        )


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
