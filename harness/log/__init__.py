"""The per-run trial log (docs/reports.md, docs/reliability.md), one job per module:

- schemas: the JSON Schemas of /run, /workspace, /query and Foxglove's /scene
- mcap_io: plain JSON values, MCAP writing helpers, `read_log` (also of a killed run's file)
- recover: reading a cut-short or damaged file record by record (`scan_log`)
- csv: queries.csv;  rerun: the Rerun sink (trials.rrd);  foxglove: /scene SceneUpdates
- painters: how each robot kind is drawn (`painter_for`, which finds each kind's `*_painter.py`), for
  Foxglove, Rerun and the report
- writer: `TrialLog`, the three files together, resume and finalisation
- process: `LogProcess`, the log in a child process that `judge`s each query
"""

from __future__ import annotations

from harness.log.csv import CSV_FIXED, CSV_NAME
from harness.log.mcap_io import MCAP_NAME, LoggedMessage, plain, read_log
from harness.log.painters import Painter, painter_for, rect_outlines, register
from harness.log.process import LogProcess, LogProcessDied, judge, starting
from harness.log.rerun import RRD_NAME
from harness.log.schemas import FORMAT, QUERY_FIELDS, RUN_FIELDS, run_segments, scene_update_schema
from harness.log.tally import Tally
from harness.log.writer import ResumeRefused, TrialLog

__all__ = [
    "CSV_FIXED",
    "CSV_NAME",
    "FORMAT",
    "MCAP_NAME",
    "QUERY_FIELDS",
    "RRD_NAME",
    "RUN_FIELDS",
    "ResumeRefused",
    "LogProcess",
    "LogProcessDied",
    "LoggedMessage",
    "Painter",
    "Tally",
    "TrialLog",
    "judge",
    "painter_for",
    "plain",
    "read_log",
    "rect_outlines",
    "register",
    "run_segments",
    "scene_update_schema",
    "starting",
]
