"""hull_kernels.hull_gap: GJK's lower bound on the distance between two posed convex hulls,
against the distance found by a quadratic program on the same vertices."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from mpnet.envs.checkers.hull_kernels import hull_gap


def qp_distance(a: np.ndarray, b: np.ndarray) -> float:
    """min |x A - y B| over barycentric weights x, y: the hulls' distance (SLSQP, tight tolerance)."""
    na, nb = len(a), len(b)

    def f(z):
        d = z[:na] @ a - z[na:] @ b
        return d @ d

    cons = [{"type": "eq", "fun": lambda z: z[:na].sum() - 1}, {"type": "eq", "fun": lambda z: z[na:].sum() - 1}]
    z0 = np.r_[np.full(na, 1 / na), np.full(nb, 1 / nb)]
    r = minimize(f, z0, constraints=cons, bounds=[(0, 1)] * (na + nb), method="SLSQP", options={"ftol": 1e-15})
    return float(np.sqrt(max(r.fun, 0.0)))


def posed_pair(seed: int):
    rng = np.random.default_rng(seed)
    va, vb = rng.normal(size=(20, 3)) * 0.1, rng.normal(size=(16, 3)) * 0.1
    ra, rb = Rotation.random(random_state=seed).as_matrix(), Rotation.random(random_state=seed + 1000).as_matrix()
    ta, tb = rng.normal(size=3) * 0.05, rng.normal(size=3) * 0.3
    verts = np.ascontiguousarray(np.vstack([va, vb]))
    return verts, ra, ta, rb, tb, va @ ra.T + ta, vb @ rb.T + tb


@pytest.mark.parametrize("seed", range(16))
def test_the_gap_is_the_hulls_distance_and_never_more(seed):
    verts, ra, ta, rb, tb, a, b = posed_pair(seed)
    exact = qp_distance(a, b)
    gap = hull_gap(verts, 0, 20, ra, ta, 20, 36, rb, tb, np.nan)  # NaN: to convergence
    assert gap <= exact + 1e-9
    assert gap >= exact - 1e-6 if exact > 1e-6 else gap <= 1e-9  # overlapping hulls: 0 or less
    # asked whether they are apart by more than a target, it answers for that target only
    for target in (0.5 * exact, 2 * exact + 1e-3) if exact > 1e-6 else (1e-3,):
        early = hull_gap(verts, 0, 20, ra, ta, 20, 36, rb, tb, target)
        assert early <= exact + 1e-9 and (early > target) == (exact > target)
