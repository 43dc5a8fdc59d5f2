"""`python -m harness.repair PATH...`: make trial logs that a kill left unfinished, or that
were damaged, readable by every MCAP reader.

A bench killed outright (`kill -9` of its process group, a node lost) leaves a
trials.mcap without the summary that indexed readers (the `mcap` CLI, Foxglove, the
`mcap` package's `make_reader`) need. The harness's own reader reads it anyway; this
rewrites its readable messages, in order and with their times, as a finalised file. A
file that only lost its last, half-written record is replaced; a damaged one (bytes lost
mid-file) is kept beside it as trials.mcap.damaged-<k>. Intact files are left alone.
Exit 1 when a file could not be read at all.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from harness.log.mcap_io import MCAP_NAME, dumps, keep_damaged, new_writer, start_channels
from harness.log.recover import scan_log
from harness.log.schemas import topic_schemas


def repair_file(path: Path) -> str:
    """Repair one file; a line saying what was done."""
    scan = scan_log(path)
    if scan.finalised and not scan.damaged:
        return f"{path}: intact, left as is"
    if not any(topic == "/run" for topic, *_ in scan.messages):
        raise ValueError(f"{path}: no readable /run message ({scan.describe_damage()}); nothing to repair")
    tmp = path.with_name(path.name + ".repair-tmp")
    topics = topic_schemas()
    with open(tmp, "wb") as f:
        w = new_writer(f)
        channels = start_channels(w, topics)
        for topic, data, log_time, publish_time in scan.messages:
            if topic in channels:
                w.add_message(channels[topic], log_time, dumps(data), publish_time)
        w.finish()
        f.flush()
        os.fsync(f.fileno())
    queries = sum(topic == "/query" for topic, *_ in scan.messages)
    if scan.damaged:
        kept = keep_damaged(path)
        os.replace(tmp, path)
        return (
            f"{path}: damaged ({scan.describe_damage()}); rewrote its {queries} readable queries, "
            f"original kept as {kept}"
        )
    os.replace(tmp, path)
    return f"{path}: unfinished (a killed writer); finalised with its {queries} queries"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.repair", description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="+", help="trials.mcap files, or run/sweep directories to search")
    args = ap.parse_args(argv)
    files, bad = [], 0
    for p in map(Path, args.paths):
        if p.is_dir():
            files += sorted(p.rglob(MCAP_NAME))
        elif p.is_file():
            files.append(p)
        else:
            print(f"error: {p}: no such file or directory", file=sys.stderr)
            bad += 1
    for f in files:
        try:
            print(repair_file(f))
        except (OSError, ValueError) as e:
            print(f"error: {e}", file=sys.stderr)
            bad += 1
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
