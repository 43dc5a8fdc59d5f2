"""What the end-of-run summary needs, per split, kept in compact arrays: the log process
holds this instead of every query's record, so its memory hardly grows with the run
(16 bytes per successful query, for the times and costs whose median and mean it prints)."""

from __future__ import annotations

from array import array
from collections import Counter
from dataclasses import dataclass, field


@dataclass
class SplitTally:
    queries: int = 0
    checks: float = 0.0
    times: array = field(default_factory=lambda: array("d"))  # of the successes
    costs: array = field(default_factory=lambda: array("d"))  # of the successes that have one
    failures: Counter = field(default_factory=Counter)


class Tally:
    """Per split: queries, collision checks, success times and costs, failures by reason."""

    def __init__(self):
        self.splits: dict[str, SplitTally] = {}

    def add(self, rec: dict) -> None:
        s = self.splits.setdefault(str(rec["split"]), SplitTally())
        s.queries += 1
        s.checks += float(rec.get("collision_checks") or 0)
        if rec["success"]:
            s.times.append(float(rec["time_s"]))
            if rec.get("path_cost") is not None:
                s.costs.append(float(rec["path_cost"]))
        else:
            s.failures[rec["failure"]] += 1

    def __len__(self) -> int:
        return sum(s.queries for s in self.splits.values())
