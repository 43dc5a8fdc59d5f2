"""The covering's compiled steps give the numpy forms' answers bit for bit (the shipped sphere
sets, hashed into every arm cache key, must not move when the covering gets faster), points on
a ball's surface included."""

from __future__ import annotations

import numpy as np

from mpnet.envs.arm.spherize import _farthest_assigned, _greedy, _holds


def _numpy_holds(centres, radii, points):
    return ((centres[:, None, :] - points[None]) ** 2).sum(-1) <= radii[:, None] ** 2


def _numpy_greedy(holds):
    open_, chosen = np.ones(holds.shape[1], bool), []
    counts = holds.sum(axis=1)
    while open_.any():
        j = int(np.argmax(counts))
        if counts[j] == 0:
            break
        chosen.append(j)
        newly = open_ & holds[j]
        open_ &= ~holds[j]
        counts -= holds[:, newly].sum(axis=1)
    return chosen, open_


def _numpy_farthest(points, centres, radii):
    farthest = np.full(len(centres), -1.0)
    d = np.sqrt(((points[:, None, :] - centres[None]) ** 2).sum(-1))
    owner = np.argmin(d - radii[None], axis=1)
    np.maximum.at(farthest, owner, d[np.arange(len(points)), owner])
    return farthest


def test_the_compiled_covering_steps_are_numpys_bit_for_bit():
    rng = np.random.default_rng(7)
    grid = np.stack(np.meshgrid(*[np.arange(0.0, 0.05, 0.005)] * 3, indexing="ij"), -1).reshape(-1, 3)
    points = np.concatenate([grid, rng.uniform(0.0, 0.05, (300, 3))])
    centres = np.concatenate([grid[::7], rng.uniform(0.0, 0.05, (40, 3))])
    # radii exactly some point's distance (ties on the surface), and random ones
    d = np.sort(np.sqrt(((centres[:, None] - points[None]) ** 2).sum(-1)), axis=1)
    radii = d[np.arange(len(centres)), rng.integers(1, 30, len(centres))]
    radii[::3] = rng.uniform(0.0, 0.01, len(radii[::3]))
    holds = _holds(centres, radii, points)
    assert np.array_equal(holds, _numpy_holds(centres, radii, points)) and holds.any() and not holds.all()
    chosen, open_ = _greedy(holds)
    want, want_open = _numpy_greedy(holds)
    assert chosen.tolist() == want and np.array_equal(open_, want_open) and len(want) > 3
    c, r = centres[chosen], radii[chosen]
    assert np.array_equal(_farthest_assigned(points, c, r), _numpy_farthest(points, c, r))
