"""Pnet's samples toward intermediate goals (waypoint_pairs' goals="all", the recipe's goal_pairs)."""

from __future__ import annotations

import numpy as np
import pytest

from mpnet.models.pairs import waypoint_pairs


def _rows(p):
    return {(tuple(a), tuple(b), tuple(c)) for a, b, c in zip(p.x_t, p.x_goal, p.x_next)}


def test_every_later_waypoint_is_a_goal_of_each_step():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 1.0], [3.0, 3.0]])
    p = waypoint_pairs([path], [7], bidirectional=False, goals="all")
    assert len(p.x_t) == 6  # (j, k), 0 <= j < k <= 3
    expected = {(tuple(path[j]), tuple(path[k]), tuple(path[j + 1])) for j in range(3) for k in range(j + 1, 4)}
    assert _rows(p) == expected
    assert set(p.ws_index) == {7} and set(p.path_id) == {0}


def test_all_goals_hold_the_path_end_pairs_and_both_directions():
    rng = np.random.default_rng(0)
    paths = [rng.normal(size=(n, 3)) for n in (2, 5, 1, 7)]
    end = waypoint_pairs(paths, [0, 1, 2, 3])
    every = waypoint_pairs(paths, [0, 1, 2, 3], goals="all")
    assert _rows(end) <= _rows(every)
    assert len(every.x_t) == sum(n * (n - 1) for n in (2, 5, 7))  # both directions, the 1-state path adds none
    np.testing.assert_array_equal(np.bincount(every.path_id), [2, 20, 0, 42])


def test_all_goals_keep_the_planners_angles():
    """With a space, goals are wrapped as the planner feeds them, targets reached from x_t."""
    from mpnet.envs import get_spec

    space = get_spec("rigid").space
    path = np.array([[0.0, 0.0, 3.0], [0.5, 0.0, -3.0], [1.0, 0.0, -2.5]])
    p = waypoint_pairs([path], [0], bidirectional=False, space=space, goals="all")
    assert np.all(np.abs(p.x_goal[:, 2]) <= np.pi)
    step = p.x_next[:, 2] - p.x_t[:, 2]
    assert np.all(np.abs(step) < 1.0)  # across pi the short way


def test_an_unknown_goal_choice_is_refused():
    with pytest.raises(ValueError, match="goals must be one of end, all"):
        waypoint_pairs([np.zeros((3, 2))], [0], goals="middle")


def test_scene_batches_see_every_sample_once_from_few_scenes():
    """scale.fit.scenes_per_batch: an epoch is a permutation of the samples; a batch spans at
    most two groups of `scenes` workspaces; the order follows torch's seed."""
    import torch

    from mpnet.models.datamodule import SceneBatches

    rng = np.random.default_rng(1)
    ws = rng.integers(0, 40, size=1000) * 3  # ids need not be 0..n-1
    sampler = SceneBatches(ws, batch_size=50, scenes=4)
    torch.manual_seed(0)
    first = list(sampler)
    assert len(first) == len(sampler) == 20
    flat = np.concatenate(first)
    np.testing.assert_array_equal(np.sort(flat), np.arange(1000))
    assert max(len(set(ws[b])) for b in first) <= 8
    assert np.mean([len(set(ws[b])) for b in first]) < 6
    torch.manual_seed(0)
    assert [list(b) for b in sampler] == [list(b) for b in first]
    assert [list(b) for b in sampler] != [list(b) for b in first]  # the next epoch draws anew
    with pytest.raises(ValueError, match="scenes_per_batch"):
        SceneBatches(ws, 10, 0)


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_the_datamodule_batches_by_scene_when_asked():
    from mpnet.models.datamodule import MPNetDataModule

    rng = np.random.default_rng(2)
    n, clouds = 600, rng.normal(size=(30, 6))
    x = rng.normal(size=(n, 2))
    ws = rng.integers(0, 30, size=n)
    plain = MPNetDataModule(clouds, ws, x, x, x, batch_size=20)
    grouped = MPNetDataModule(clouds, ws, x, x, x, batch_size=20, scenes_per_batch=2)  # groups of ~40 samples
    k_plain = [len(b["clouds"]) for b in plain.train_dataloader()]
    k_grouped = [len(b["clouds"]) for b in grouped.train_dataloader()]
    assert len(k_plain) == len(k_grouped) and max(k_grouped) <= 4 < np.mean(k_plain)
    assert sum(len(b["ws"]) for b in grouped.train_dataloader()) == len(grouped.train_indices)
    assert len(grouped.val_dataloader()) == len(plain.val_dataloader())  # validation is not regrouped
