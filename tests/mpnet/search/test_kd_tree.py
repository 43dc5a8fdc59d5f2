"""The k-d tree answers what the linear scan answers, index for index: the least squared
distance, the lowest index of equals, with repeated states, ties on a grid, trees too deep
or too full to use (the scan then), and arrays grown mid-search."""

import numpy as np
import pytest

from mpnet.envs import get_spec
from mpnet.envs.scenes.generators import make_workspace
from mpnet.search import kd_tree as T
from mpnet.search import rrt_kernels as K


@pytest.fixture(scope="module")
def env():
    spec = get_spec("panda_mbm")
    return spec.make_checker(make_workspace(spec, 0, "train")).compiled_env()


def grown_tree(points, t=1, cap=None):
    """points inserted one by one as tree t's states (cols (2, d, cap)); its kd arrays."""
    n, d = points.shape
    cap = cap or n
    cols = np.zeros((2, d, cap))
    cols[t, :, :n] = points.T
    kd = T.kd_arrays(cap)
    T.kd_reset(kd, t)
    for s in range(n):
        T.kd_insert(kd, t, s, cols)
    return cols, kd


def scan(env, points, q):
    n, d = points.shape
    return K.nearest(env, np.ones(d), points, np.ascontiguousarray(points.T), n, q, np.empty(d), np.empty(n))


@pytest.mark.parametrize("seed", range(8))
def test_the_tree_finds_the_node_the_scan_finds(env, seed):
    rng = np.random.default_rng(seed)
    d, n = 7, int(rng.integers(1, 4000))
    if seed % 3 == 0:  # a random walk, as an RRT tree grows
        points = np.cumsum(rng.normal(0, 0.2, (n, d)), axis=0)
    elif seed % 3 == 1:  # a coarse grid: many equal distances
        points = rng.integers(-3, 4, (n, d)).astype(float)
    else:  # uniform, a third of the states repeated
        points = rng.uniform(-3, 3, (n, d))
        points[rng.integers(0, n, n // 3)] = points[rng.integers(0, n, n // 3)]
    cols, kd = grown_tree(points)
    assert kd[5][1, T.OFF] == 0 or seed % 3 == 1
    for _ in range(300):
        q = points[rng.integers(n)] if rng.random() < 0.3 else rng.uniform(-4, 4, d)
        if seed % 3 == 1:
            q = np.round(q)
        got = T.kd_nearest(kd, 1, cols, q)
        assert got == -1 and kd[5][1, T.OFF] == 1 or got == scan(env, points, q)


def test_a_leaf_of_equal_states_turns_the_tree_off_and_the_scan_answers(env):
    points = np.zeros((T.LEAF + 5, 3))
    cols, kd = grown_tree(points, t=0)
    assert kd[5][0, T.OFF] == 1 and T.kd_nearest(kd, 0, cols, np.ones(3)) == -1


def test_too_few_kd_nodes_turns_the_tree_off(env):
    rng = np.random.default_rng(1)
    points = rng.uniform(-1, 1, (3000, 4))
    cols, kd = grown_tree(points, cap=3000)
    small = T.kd_arrays(40)  # 18 kd nodes: fewer than 3000 states need
    T.kd_reset(small, 1)
    for s in range(3000):
        T.kd_insert(small, 1, s, cols)
    assert small[5][1, T.OFF] == 1 and T.kd_nearest(small, 1, cols, np.zeros(4)) == -1
    assert kd[5][1, T.OFF] == 0 and T.kd_nearest(kd, 1, cols, np.zeros(4)) == scan(env, points, np.zeros(4))


def test_grown_arrays_keep_the_tree(env):
    rng = np.random.default_rng(2)
    points = rng.uniform(-1, 1, (2000, 7))
    cols, kd = grown_tree(points[:1000], cap=1000)
    big = np.zeros((2, 7, 2000))
    big[:, :, :1000] = cols
    big[1, :, 1000:] = points[1000:].T
    kd = T.kd_grown(kd, T.kd_arrays(2000))
    for s in range(1000, 2000):
        T.kd_insert(kd, 1, s, big)
    for q in rng.uniform(-1.2, 1.2, (200, 7)):
        assert T.kd_nearest(kd, 1, big, q) == scan(env, points, q)
