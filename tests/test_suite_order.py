"""The suite's own set-up (tests/conftest.py): how the ordered tests are dealt to xdist's workers."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from tests.conftest import deal


def worksteal_shares(items: list, n: int) -> list[list]:
    """pytest-xdist 3.8's first hand-out (WorkStealingScheduling.check_schedule): to each idle
    worker in turn, len(pending) // (workers left) of the pending tests, from the front."""
    out, pending = [], list(items)
    for j in range(n):
        k = len(pending) // (n - j)
        out.append(pending[:k])
        del pending[:k]
    return out


@given(st.integers(0, 200), st.integers(1, 8))
def test_each_worker_gets_every_nth_test_in_order(length, n):
    ordered = list(range(length))
    shares = worksteal_shares(deal(ordered, n), n)
    assert sorted(x for share in shares for x in share) == ordered  # each test once
    for share in shares:
        assert share == sorted(share) and all(b - a == n for a, b in zip(share, share[1:]))
    assert sorted(share[0] for share in shares if share) == list(range(min(n, length)))  # all start at the front
