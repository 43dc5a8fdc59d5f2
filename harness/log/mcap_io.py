"""`trials.mcap` at the byte level: plain JSON values, the writer's channels, and the reader
that also reads a file whose writer was killed (docs/reliability.md, "Results you can trust")."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

MCAP_NAME = "trials.mcap"
RESUME_SUFFIX = ".resume-"  # trials.mcap.resume-<k>: a previous file moved aside on resume
DAMAGED_SUFFIX = ".damaged-"  # trials.mcap.damaged-<k>: a damaged earlier file, kept as it was


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


def dumps(msg: dict) -> bytes:
    """A message's compact, strict JSON (plain() values)."""
    return json.dumps(msg, separators=(",", ":"), allow_nan=False).encode()


def new_writer(f: BinaryIO) -> Writer:
    """A zstd-chunked MCAP writer on `f`; each writer.flush() closes a chunk, so what was
    flushed stays readable after a kill."""
    return Writer(f, compression=CompressionType.ZSTD)


def start_channels(w: Writer, topics: Iterable[tuple[str, str, bytes]]) -> dict[str, int]:
    """Start `w` and register each (topic, schema name, schema) of harness.log.schemas.topic_schemas():
    the channel id per topic."""
    w.start(profile="", library="mpnet-bench")
    channels = {}
    for topic, name, schema in topics:
        sid = w.register_schema(name, "jsonschema", schema)
        channels[topic] = w.register_channel(topic, "json", sid)
    return channels


def aside_index(p: Path) -> int:
    """k of trials.mcap.resume-<k> (files are re-read oldest first)."""
    tail = p.name.rsplit("-", 1)[-1]
    return int(tail) if tail.isdigit() else 0


def keep_damaged(path: Path) -> Path:
    """Move a damaged log to the next free trials.mcap.damaged-<k> beside it (never
    overwritten, never deleted); its new path."""
    k = 1 + max(map(aside_index, path.parent.glob(MCAP_NAME + DAMAGED_SUFFIX + "*")), default=0)
    kept = path.with_name(MCAP_NAME + DAMAGED_SUFFIX + str(k))
    os.replace(path, kept)
    return kept


@dataclass
class LoggedMessage:
    topic: str
    data: dict
    log_time: int
    publish_time: int


def read_log(path: str | Path, topics: Iterable[str] | None = None) -> tuple[list[LoggedMessage], bool]:
    """All readable JSON messages of a trials.mcap, and whether the file was finalised.

    A finalised, intact file is read through its index (CRCs checked); any other file, one
    whose writer was killed or one with damaged bytes, record by record (harness.log.recover),
    keeping every message that can still be read.
    """
    from harness.log.recover import scan_log

    topics = None if topics is None else set(topics)
    try:
        with open(path, "rb") as f:
            out = [
                LoggedMessage(c.topic, json.loads(m.data), m.log_time, m.publish_time)
                for _, c, m in make_reader(f, validate_crcs=True).iter_messages(topics=topics, log_time_order=False)
            ]
        return out, True
    except OSError:
        raise
    except Exception:  # noqa: BLE001 - any failure means: not a finalised, intact file
        pass
    scan = scan_log(path, topics)
    return [LoggedMessage(*m) for m in scan.messages], scan.finalised and not scan.damaged
