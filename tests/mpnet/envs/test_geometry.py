"""The one slab test (mpnet.envs.geometry): known answers, and its callers answer as the numpy
they replaced (tests/oracles.py), bit for bit: the exact 2D reference's visibility and the depth
camera's boxes, on segments along edges and through corners and rays that stand still in a
coordinate or start on a face."""

from __future__ import annotations

import math

import numpy as np

from mpnet.envs.geometry import clip
from mpnet.envs.scenes import camera
from mpnet.envs.scenes.generators import make_workspace
from mpnet.envs.specs import get_spec
from mpnet.planners.reference import EPS, visible
from tests import oracles as O

LO, HI = np.array([[1.0, -1.0]]), np.array([[3.0, 1.0]])


def test_clip_known_answers():
    a = np.array([0.0, 0.0])
    for reciprocal in (False, True):
        assert clip(a, np.array([2.0, 0.0]), LO, HI, 0, 0.0, 1.0, reciprocal) == (0.5, 1.0)  # enters halfway
        assert clip(a, np.array([4.0, 0.0]), LO, HI, 0, -math.inf, math.inf, reciprocal) == (0.25, 0.75)
        t0, t1 = clip(a, np.array([0.5, 0.0]), LO, HI, 0, 0.0, 1.0, reciprocal)  # stops short
        assert t0 > t1
        t0, t1 = clip(np.array([2.0, 2.0]), np.array([1.0, 0.0]), LO, HI, 0, 0.0, 1.0, reciprocal)  # above, level
        assert (t0, t1) == (math.inf, -math.inf)
    # along the top face: a closed box is met
    assert clip(np.array([0.0, 1.0]), np.array([4.0, 0.0]), LO, HI, 0, 0.0, 1.0, False) == (0.25, 0.75)


def _corners(lo, hi):
    return np.concatenate([lo, hi, np.stack([lo[:, 0], hi[:, 1]], 1), np.stack([hi[:, 0], lo[:, 1]], 1)])


def test_visibility_is_the_numpy_clipping_it_replaced_bit_for_bit():
    rng = np.random.default_rng(0)
    for env in ("s2d", "c2d"):
        spec = get_spec(env)
        for index in range(3):
            ws = make_workspace(spec, index, "train")
            nodes = np.concatenate([_corners(ws.lo, ws.hi), rng.uniform(-20.0, 20.0, (20, 2))])
            want = O.segments_visible(nodes, nodes, ws.lo, ws.hi, EPS)
            assert np.array_equal(visible(nodes, nodes, ws.lo, ws.hi), want) and not want.all()
    empty = np.zeros((0, 2))
    seen = visible(nodes, nodes[:3], empty, empty)
    assert seen.all() and seen.shape == (len(nodes), 3)


def test_a_box_seen_by_the_camera_is_the_numpy_slab_test_it_replaced_bit_for_bit():
    rng = np.random.default_rng(1)
    half = np.array([0.3, 0.2, 0.5])
    d = rng.normal(size=(3000, 3))
    d[rng.random(d.shape) < 0.2] = 0.0  # rays level in a coordinate
    d[np.abs(d).sum(1) == 0.0] = [1.0, 0.0, 0.0]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for o in ([-1.0, 0.05, 0.1], [-1.0, 0.2, -0.5], [0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [2.0, -0.2, 0.4]):
        o = np.array(o)  # outside; level with two faces; inside; on a face; beyond the far side
        got = camera._box(o, d, half)
        assert np.array_equal(got, O.ray_box_entries(np.broadcast_to(o, d.shape), d, half))
        assert np.isfinite(got).any() == (abs(o[0]) != 0.0 and o[0] != 0.3)  # from inside or a face: none
