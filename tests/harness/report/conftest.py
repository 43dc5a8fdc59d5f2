"""The report's tests' known logs (tests/harness/report/_helpers.py) as a fixture."""

from __future__ import annotations

import pytest

from tests.harness.report._helpers import Q, write_log


@pytest.fixture()
def known(tmp_path):
    """s2d: mpnet_nr seeds 0 and 1, bit_star seed 0 logged twice (two files)."""
    logs = tmp_path / "logs"
    nr = {"pnet_calls": 4, "replans": 1, "fallback_used": False}
    write_log(
        logs / "nr0",
        "s2d",
        "mpnet_nr",
        0,
        [
            Q("seen", "0", 0, True, 0.1, cost=10.0, checks=10, stats=nr),
            Q("seen", "0", 1, True, 0.2, cost=20.0, checks=20, stats={**nr, "pnet_calls": 6, "replans": 0}),
            Q("seen", "1", 0, True, 0.3, cost=30.0, checks=30, stats={**nr, "fallback_used": True}),
            Q("seen", "1", 1, False, 9.0, checks=999, stats=nr),
            Q("unseen", "100", 0, True, 0.5, cost=5.0, stats=nr),
        ],
    )
    write_log(
        logs / "nr1",
        "s2d",
        "mpnet_nr",
        1,
        [
            Q("seen", "0", 0, True, 0.4, cost=40.0, checks=40, stats=nr),
            Q("seen", "0", 1, False, 1.0, failure="no_solution", stats=nr),
        ],
    )
    ref = {"reference_cost": 10.0}  # BIT* logs its best cost over time; with a reference, quality too
    for k in ("a", "b"):
        write_log(
            logs / k / "bit0",
            "s2d",
            "bit_star",
            0,
            [
                Q("seen", "0", 0, True, 2.0, cost=12.0, stats={"progress": [[0.5, 20.0], [1.5, 12.0]], **ref}),
                Q("seen", "0", 1, True, 3.0, cost=14.0, stats={"progress": [[1.0, 14.0]], **ref}),
            ],
        )
    return logs
