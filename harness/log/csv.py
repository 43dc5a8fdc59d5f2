"""queries.csv: the scalar fields of each query, a flat table beside the MCAP record."""

from __future__ import annotations

import csv
import os
from collections.abc import Iterable
from pathlib import Path

from harness.log.schemas import QUERY_FIELDS, query_columns

CSV_NAME = "queries.csv"
# Scalar columns of queries.csv that always come first, in this order: the required /query
# fields a column holds (the schema's).
CSV_FIXED = tuple(f for f in QUERY_FIELDS if f in query_columns())
_NON_CSV = frozenset(("start", "goal", "path", "partial"))


class QueryCsv:
    """One row per query, flushed per row.

    Columns are the fixed fields, then `extra_fields`, then other scalar keys in the order
    first seen; a key first seen late rewrites the file (atomically) with the wider header,
    reading the earlier rows back from the file, so no row is held in memory.
    """

    def __init__(self, path: Path, extra_fields: Iterable[str]):
        self.path = path
        self.cols = list(CSV_FIXED) + [k for k in extra_fields if k not in CSV_FIXED]
        self._known = set(self.cols)
        self._open(rewrite=False)

    def _open(self, rewrite: bool):
        tmp = self.path.with_name(self.path.name + ".tmp")
        f = open(tmp if rewrite else self.path, "w", newline="", encoding="utf-8")
        w = csv.DictWriter(f, self.cols, restval="", extrasaction="ignore")
        w.writeheader()
        if rewrite:
            with open(self.path, newline="", encoding="utf-8") as old:
                w.writerows(csv.DictReader(old))
            f.flush()
            os.replace(tmp, self.path)
        self.f, self.w = f, w
        f.flush()

    def add(self, msg: dict):
        flat = dict(msg)
        for k, v in msg.items():  # one level of nesting (diagnostics): "diagnostics.key" columns
            if isinstance(v, dict):
                flat.update((f"{k}.{kk}", vv) for kk, vv in v.items())
        row = {k: v for k, v in flat.items() if k not in _NON_CSV and (v is None or type(v) in (str, int, float, bool))}
        new = [k for k in row if k not in self._known]
        if new:
            self.cols += new
            self._known.update(new)
            self.f.close()
            self._open(rewrite=True)
        self.w.writerow(row)
        self.f.flush()

    def close(self):
        try:
            self.f.close()
        except Exception:  # noqa: BLE001
            pass
