"""Reading a trials.mcap that was cut short or damaged, record by record.

The indexed reader needs the summary a finished writer appends; a killed writer leaves
none, and one flipped byte makes the stream reader stop there. This walk reads every
record it can: a chunk whose CRC or compression fails is skipped (the records around it
have intact lengths), and a broken record header is passed by searching for the next chunk
that parses and matches its CRC. What could not be read is reported as byte ranges, so
resume and the report say what was lost instead of dropping it quietly, and `repair`
rewrites the readable messages as a finalised file that any MCAP reader opens.

Hand-written over the `mcap` package's record classes because the package's readers stop
at the first error and do not say where.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Schema
from mcap.stream_reader import MAGIC_SIZE, breakup_chunk

from harness.log.schemas import topic_schemas

MAGIC = bytes([137, 77, 67, 65, 80, 48, 13, 10])
_KNOWN = {int(op) for op in Opcode}
_HEAD = struct.Struct("<BQ")


@dataclass
class LogScan:
    """What a walk over a trials.mcap found: its JSON messages in file order as
    (topic, data, log_time, publish_time), whether the writer finished it (a footer),
    whether it ends inside a record (a writer killed mid-write: harmless), and the byte
    ranges that could not be read (damage: messages in them are lost)."""

    messages: list[tuple[str, dict, int, int]] = field(default_factory=list)
    finalised: bool = False
    cut_tail: bool = False
    damaged: list[tuple[int, int]] = field(default_factory=list)
    size: int = 0
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)

    @property
    def damaged_bytes(self) -> int:
        return sum(b - a for a, b in self.damaged)

    def describe_damage(self) -> str:
        spans = ", ".join(f"{a}-{b}" for a, b in self.damaged[:3]) + (" ..." if len(self.damaged) > 3 else "")
        return f"{self.damaged_bytes} of {self.size} bytes unreadable (at {spans})"


def _record(op: int, body: bytes):
    stream = ReadDataStream(BytesIO(body))
    if op == Opcode.CHUNK:
        chunk = Chunk.read(stream)
        # Damage in a chunk's own fields can zero its CRC (0: "not computed", so nothing is
        # validated; the writer always computes one) and its data length (an empty chunk that
        # parses): its fields must fill the record, and the CRC be there.
        if stream.count != len(body) or chunk.uncompressed_crc == 0:
            raise ValueError("chunk fields do not fill its record, or it has no CRC")
        return breakup_chunk(chunk, validate_crc=True)
    if op == Opcode.SCHEMA:
        return [Schema.read(stream)]
    if op == Opcode.CHANNEL:
        return [Channel.read(stream)]
    if op == Opcode.MESSAGE:
        return [Message.read(stream, len(body))]
    if op == Opcode.FOOTER:
        return [Footer.read(stream)]
    if op == Opcode.DATA_END:
        return [DataEnd.read(stream)]
    return []  # indexes, statistics, summary: rebuilt by any writer, not needed to read


def _parse_at(buf: bytes, pos: int):
    """(records, end) of the record at pos, or None when it does not parse there."""
    if len(buf) - pos < _HEAD.size:
        return None
    op, length = _HEAD.unpack_from(buf, pos)
    end = pos + _HEAD.size + length
    if op not in _KNOWN or end > len(buf):
        return None
    try:
        return _record(op, buf[pos + _HEAD.size : end]), end
    except Exception:  # noqa: BLE001 - any parse, CRC or decompression failure: not readable here
        return None


def _next_chunk(buf: bytes, pos: int):
    """The next offset after pos where a whole chunk parses with its CRC, or None."""
    marker = bytes([Opcode.CHUNK])
    i = buf.find(marker, pos)
    while i != -1:
        got = _parse_at(buf, i)
        if got is not None:
            return i, got
        i = buf.find(marker, i + 1)
    return None


def scan_log(path: str | Path, topics=None) -> LogScan:
    """Every readable JSON message of the file (those of `topics` when given)."""
    buf = Path(path).read_bytes()
    out = LogScan(size=len(buf))
    topics = None if topics is None else set(topics)
    raw: list[Message] = []
    pos = MAGIC_SIZE
    if buf[:MAGIC_SIZE] != MAGIC:
        if not buf:
            return out
        out.damaged.append((0, min(MAGIC_SIZE, len(buf))))
    while pos < len(buf):
        got = _parse_at(buf, pos)
        if got is None:
            op, length = _HEAD.unpack_from(buf, pos) if len(buf) - pos >= _HEAD.size else (None, 0)
            nxt = _next_chunk(buf, pos + 1)
            if nxt is None:
                if op is None or (op in _KNOWN and pos + _HEAD.size + length > len(buf)):
                    out.cut_tail = True  # the last record was being written when the writer died
                else:
                    out.damaged.append((pos, len(buf)))
                break
            out.damaged.append((pos, nxt[0]))
            pos, got = nxt[0], nxt[1]
        records, pos = got
        for rec in records:
            if isinstance(rec, Schema):
                out.schemas[rec.id] = rec
            elif isinstance(rec, Channel):
                out.channels[rec.id] = rec
            elif isinstance(rec, Message):
                raw.append(rec)
            elif isinstance(rec, Footer):
                out.finalised = True
        if out.finalised:
            break
    # Channels are resolved at the end: they may come from the summary, or, when the chunk
    # that declared them is lost, from the order in which the writer registers them.
    names = {i + 1: topic for i, (topic, _, _) in enumerate(topic_schemas())}
    names.update({k: c.topic for k, c in out.channels.items()})
    for rec in raw:
        topic = names.get(rec.channel_id)
        if topic is None or (topics is not None and topic not in topics):
            continue
        try:
            data = json.loads(rec.data)
        except ValueError:
            continue
        out.messages.append((topic, data, rec.log_time, rec.publish_time))
    return out
