"""trials.rrd: the run as a Rerun recording. Each workspace's obstacles, and on the `query`
timeline each query's path, start and goal over the obstacles of its workspace, with
time and collision-check plots. What is drawn comes from the painter."""

from __future__ import annotations

import time
import uuid
import warnings
from pathlib import Path

import numpy as np

from harness.log.painters import Painter
from harness.log.style import LEGEND

RRD_NAME = "trials.rrd"


class RerunSink:
    """Queries are buffered and sent as columns (`send_columns`), which costs a few
    microseconds per query instead of ~0.2 ms per query with rr.log."""

    def __init__(self, path: Path, run: dict, painter: Painter, bounds: list, batch: int, every_s: float):
        import rerun as rr
        import rerun.blueprint as rrb

        self.rr = rr
        self.painter = painter
        self.planner = run.get("planner", "")
        self.batch, self.every_s = max(1, int(batch)), every_s
        self.pending: list[tuple[int, dict, dict]] = []
        self.last_send = time.monotonic()
        self.shown_ws: tuple[str, str] | None = None
        self.shown_partial: set[str] = set()  # the kinds of partial paths on screen
        rid = uuid.uuid5(uuid.NAMESPACE_URL, "mpnet-bench:" + str(path.resolve().parent))
        self.rec = rr.RecordingStream("mpnet_bench", recording_id=rid)
        self.rec.save(path, default_blueprint=self._blueprint(rrb, bounds))
        self.rec.send_recording_name(f"{run.get('env')} {run.get('planner')} seed {run.get('seed')}")
        for entity, archetype in painter.rerun_static(rr, bounds):
            self.rec.log(entity, archetype, static=True)
        self.rec.log("legend", rr.TextDocument(legend(run), media_type=rr.MediaType.MARKDOWN), static=True)

    def _blueprint(self, rrb, bounds: list):
        scene = self.painter.rerun_view(rrb, bounds)
        plots = rrb.Vertical(
            rrb.TextDocumentView(name="legend", origin="/legend"),
            rrb.TimeSeriesView(name="planning time [s]", origin="/stats/time_s"),
            rrb.TimeSeriesView(name="collision checks", origin="/stats/collision_checks"),
            row_shares=[2, 1.5, 1.5],  # the legend (8 colours) shown whole
        )
        return rrb.Blueprint(
            rrb.Horizontal(scene, plots, column_shares=[2, 1]), rrb.TimePanel(timeline="query"), collapse_panels=True
        )

    def workspace(self, ws_msg: dict):
        for sub, archetype in self.painter.rerun_obstacle_entities(self.rr, ws_msg):
            path = ["workspaces", ws_msg["split"], ws_msg["workspace_id"], "obstacles"] + ([sub] if sub else [])
            self.rec.log(path, archetype, static=True)

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
            warnings.warn(
                f"trial log: {len(items)} queries missing from trials.rrd: {e!r}", RuntimeWarning, stacklevel=3
            )

    def _send(self, items):
        """Columns, one row per query on the `query` timeline."""
        rr, rec = self.rr, self.rec
        for i, _msg, ws in items:  # obstacles of the workspace on screen, when it changes
            key = (ws["split"], ws["workspace_id"])
            if key != self.shown_ws:
                rec.set_time("query", sequence=i)
                for sub, archetype in self.painter.rerun_obstacle_entities(rr, ws):
                    rec.log("scene/world/obstacles" + (f"/{sub}" if sub else ""), archetype)
                self.shown_ws = key
        idx = [rr.TimeColumn("query", sequence=[i for i, _, _ in items])]
        msgs = [m for _, m, _ in items]
        rec.send_columns(
            "stats/time_s",
            indexes=idx,
            columns=rr.Scalars.columns(scalars=np.array([_num(m.get("time_s")) for m in msgs], float)),
        )
        rec.send_columns(
            "stats/collision_checks",
            indexes=idx,
            columns=rr.Scalars.columns(scalars=np.array([_num(m.get("collision_checks")) for m in msgs], float)),
        )
        for entity, columns in self.painter.rerun_queries(rr, msgs, str(self.planner)):
            rec.send_columns(entity, indexes=idx, columns=columns)
        seq = [i for i, _, _ in items]
        for entity, rows, columns in self.painter.rerun_partials(rr, msgs, str(self.planner), self.shown_partial):
            rec.send_columns(entity, indexes=[rr.TimeColumn("query", sequence=[seq[r] for r in rows])], columns=columns)

    def close(self):
        try:
            self.send()
        finally:
            self.rec.flush()
            self.rec.disconnect()


def legend(run: dict) -> str:
    """What the recording shows, and what its colours mean (the scene has no legend of its own)."""
    lines = "".join(f"- {words}\n" for words, _ in LEGEND)
    return (
        f"**{run.get('planner')}** on **{run.get('env')}**, seed {run.get('seed')} ({run.get('split')})\n\n"
        f"{lines}"
        "- labels: planner, split, query, and the outcome (a failure's reason) or the partial path's kind\n"
        "- a failure's partial paths show what the planner had when it stopped (`scene/world/partial`)\n"
        "- timeline `query`: one query after another"
    )


def _num(v) -> float:
    return float("nan") if v is None else float(v)
