"""MPNet's DataModules (mpnet.models.datamodule): the split, Pnet's waypoint pairs, resampled
paths, the batches."""

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet import models  # its DataModules load on first use, not as pytest collects
from mpnet.models import resample_path, split_indices, waypoint_pairs
from tests.mpnet.models._helpers import _pair_data

# --------------------------------------------------------------------------- data modules


def test_split_is_deterministic_disjoint_and_grouped():
    tr, va = split_indices(100, 0.2, seed=3)
    tr2, va2 = split_indices(100, 0.2, seed=3)
    assert np.array_equal(tr, tr2) and np.array_equal(va, va2)
    assert len(va) == 20 and np.array_equal(np.sort(np.concatenate((tr, va))), np.arange(100))
    assert not np.array_equal(va, split_indices(100, 0.2, seed=4)[1])
    groups = np.repeat(np.arange(10), 5)
    tr, va = split_indices(50, 0.3, seed=0, groups=groups)
    assert not set(groups[tr]) & set(groups[va]) and len(set(groups[va])) == 3
    assert len(split_indices(2, 0.01, 0)[1]) == 1 and len(split_indices(5, 0.0, 0)[1]) == 0


def test_waypoint_pairs_both_directions():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    p = waypoint_pairs([path, path[:1]], [4, 5])
    assert len(p.x_t) == 4 and set(p.ws_index) == {4} and set(p.path_id) == {0}
    np.testing.assert_array_equal(p.x_t[:2], path[:2])
    np.testing.assert_array_equal(p.x_next[:2], path[1:])
    np.testing.assert_array_equal(p.x_goal[:2], [path[-1]] * 2)
    np.testing.assert_array_equal(p.x_t[2:], path[::-1][:2])
    np.testing.assert_array_equal(p.x_goal[2:], [path[0]] * 2)
    assert len(waypoint_pairs([path], [0], bidirectional=False).x_t) == 2


def test_waypoint_pairs_across_pi_train_on_wrapped_inputs():
    """A rigid path that crosses theta = +-pi (and one stored unwrapped): Pnet's inputs are
    wrapped, as the planner feeds them; each target is the next state as the motion reaches
    it from the input (3.0 -> 3.0 + 0.283, not -3.0), within a step of [-pi, pi)."""
    from mpnet.envs import get_spec

    space = get_spec("rigid").space
    wrapped = np.array([[0.0, 0.0, 3.0], [1.0, 0.0, -3.0], [2.0, 0.0, -2.5]])
    unwrapped = np.array([[0.0, 0.0, 3.0], [1.0, 0.0, 2 * np.pi - 3.0], [2.0, 0.0, 2 * np.pi - 2.5]])
    for path in (wrapped, unwrapped):
        p = waypoint_pairs([path], [0], space=space)
        for x in (p.x_t, p.x_goal):
            assert np.all((x[:, 2] >= -np.pi) & (x[:, 2] < np.pi))
        np.testing.assert_allclose(p.x_next[0], [1.0, 0.0, 2 * np.pi - 3.0])
        np.testing.assert_allclose(p.x_t[1], [1.0, 0.0, -3.0])
        np.testing.assert_allclose(
            np.abs(space.difference(p.x_t, p.x_next)[:, 2]), np.abs(p.x_next[:, 2] - p.x_t[:, 2])
        )
        np.testing.assert_allclose(space.wrap(p.x_next), space.wrap(np.concatenate([path[1:], path[-2::-1]])))


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.lists(st.floats(-3, 3), min_size=7, max_size=7), min_size=2, max_size=6),
    st.floats(0.05, 2.0),
)
def test_resampled_paths_keep_their_states_and_take_steps_of_at_most_the_step(states, step):
    """mpnet_nr_dense's training paths: the expert's states all kept, in order, every step at
    most `waypoint_step` (the space's distance), the segments' lengths unchanged."""
    from mpnet.envs import get_spec

    space = get_spec("panda_mbm").space
    path = np.array(states)
    out = resample_path(path, step, space)
    steps = np.linalg.norm(np.diff(out, axis=0), axis=1)
    assert np.all(steps <= step + 1e-9)
    assert np.isclose(steps.sum(), np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
    at = 0  # each expert state found in order, after the previous one
    for q in path[1:]:
        at += 1 + int(np.flatnonzero(np.all(np.isclose(out[at + 1 :], q), axis=1))[0])
    assert at == len(out) - 1 and np.array_equal(out[0], path[0])
    pairs = waypoint_pairs([path], [0], space=space, waypoint_step=step)
    assert len(pairs.x_t) == 2 * (len(out) - 1)


def test_resample_path_refuses_a_step_that_is_not_positive():
    with pytest.raises(ValueError, match="waypoint_step"):
        resample_path(np.zeros((2, 2)), 0.0)


def test_mpnet_datamodule_batches():
    clouds, ws, x_t, x_goal, x_next = _pair_data(n=300)
    dm = models.MPNetDataModule(clouds, ws, x_t, x_goal, x_next, batch_size=64, val_fraction=0.25, seed=1)
    assert (dm.state_dim, dm.cloud_dim) == (2, 120)
    assert len(dm.val_indices) == 75
    dm.setup("fit")
    seen = []
    for b in dm.val_dataloader():
        assert b["clouds"].dtype == torch.float32 and b["x_t"].dtype == torch.float32
        assert len(b["clouds"]) == len(torch.unique(b["ws"]))
        seen.append(b)
    rows = dm.val_indices[:64]  # validation is not shuffled
    np.testing.assert_allclose(seen[0]["clouds"][seen[0]["ws"]].numpy(), clouds[ws[rows]])
    np.testing.assert_allclose(seen[0]["x_next"].numpy(), x_next[rows], rtol=1e-6)
    assert sum(len(b["x_t"]) for b in dm.train_dataloader()) == 225
    with pytest.raises(ValueError):
        models.MPNetDataModule(clouds, ws + 100, x_t, x_goal, x_next, 8, 0.1, 0)
    with pytest.raises(ValueError):
        models.MPNetDataModule(clouds, ws, x_t, x_goal[:-1], x_next, 8, 0.1, 0)
    cdm = models.CloudDataModule(clouds, batch_size=5, val_fraction=0.25, seed=0)
    cdm.setup("fit")
    assert [tuple(b.shape) for b in cdm.val_dataloader()] == [(3, 120)]


def test_min_waypoints_resamples_each_path_to_at_least_that_many_states():
    """The paper's Baxter paths were MoveIt's interpolated trajectories (at least 10 states):
    every path gets at least min_waypoints states (its own kept, in order), and
    waypoint_step still bounds the spacing where it is shorter."""
    rng = np.random.default_rng(0)
    paths = [np.cumsum(rng.uniform(-1, 1, (n, 3)), axis=0) for n in (2, 3, 5, 14)]
    for n in (2, 10, 25):
        pairs = waypoint_pairs(paths, list(range(4)), bidirectional=False, min_waypoints=n)
        counts = np.bincount(pairs.path_id, minlength=4) + 1  # states = forward pairs + 1
        assert np.all(counts >= np.array([max(n, len(p)) if n > 2 else len(p) for p in paths]))
        for i, p in enumerate(paths):
            states = np.vstack([pairs.x_t[pairs.path_id == i], pairs.x_next[pairs.path_id == i][-1:]])
            assert all(any(np.allclose(q, s) for s in states) for q in p)  # the path's own states stay
    fine = waypoint_pairs(paths, list(range(4)), bidirectional=False, min_waypoints=3, waypoint_step=0.1)
    assert np.max(np.linalg.norm(fine.x_next - fine.x_t, axis=1)) <= 0.1 + 1e-9
    with pytest.raises(ValueError, match="min_waypoints"):
        waypoint_pairs(paths, list(range(4)), min_waypoints=1)
