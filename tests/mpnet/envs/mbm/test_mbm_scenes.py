"""MotionBenchMaker's Panda scene families as generators (mpnet.envs.mbm.scenes): the data
reads as MBM's files say, scenes vary as MBM's SceneSampler varies them, and the queries'
panda_link8 targets come out as MBM's ProblemGenerator computes them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.envs.mbm.scenes import default_start, families, ik_tip

SCENES = "panda_scenes.yaml"
FAMILIES = families(SCENES)


class _Zero:
    """A generator whose every uniform draw is the middle of its range: the nominal scene."""

    def uniform(self, lo, hi):
        return (np.asarray(lo, float) + np.asarray(hi, float)) / 2


def test_the_seven_families_and_the_start():
    assert sorted(FAMILIES) == sorted(
        ["bookshelf_small", "bookshelf_tall", "bookshelf_thin", "box", "cage", "table_pick", "table_under_pick"]
    )
    assert np.allclose(default_start(SCENES), [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    assert ik_tip(SCENES) == "panda_link8"  # the end of MBM's SRDF planning chain, from the file
    assert FAMILIES["table_under_pick"].starts is not None
    assert all(f.starts is None for n, f in FAMILIES.items() if n != "table_under_pick")


def test_nominal_scene_is_the_file_moved_by_base_offset():
    """bookshelf_small's Can1 at file (0.9, 0, 1.08) + base_offset (0.2, 0, -0.7)."""
    f = FAMILIES["bookshelf_small"]
    poses = f.sample(_Zero())
    assert np.allclose(poses["Can1"][:3, 3], [1.1, 0.0, 0.38])
    assert np.allclose(poses["shelf_top"][:3, 3], [1.2, 0.0, 0.6])
    (can,) = [p for p in f.primitives(poses) if np.allclose(p.center, [1.1, 0.0, 0.38])]
    assert can.type == "cylinder" and can.radius == pytest.approx(0.03) and can.height == pytest.approx(0.14)


def test_bookshelf_goal_targets_link8_in_front_of_the_can():
    """MBM's shelf query (offset (-0.2, 0, 0.05)) and ee_offset put panda_link8 0.12 in front
    of the can and 0.05 above it, its z axis pointing into the shelf (+x)."""
    f = FAMILIES["bookshelf_small"]
    poses = f.sample(_Zero())
    t = f.tip_targets(poses, f.goals)["Can1"]
    assert np.allclose(t[:3, 3], [1.1 - 0.12, 0.0, 0.38 + 0.05], atol=1e-3)
    assert np.allclose(t[:3, 2], [1.0, 0.0, 0.0], atol=1e-3)


def test_box_goal_is_top_down_above_the_can():
    f = FAMILIES["box"]
    poses = f.sample(_Zero())
    t = f.tip_targets(poses, f.goals)["Can1"]
    assert np.allclose(t[:3, 3], poses["Can1"][:3, 3] + [0.0, 0.0, 0.17], atol=1e-3)
    assert np.allclose(t[:3, 2], [0.0, 0.0, -1.0], atol=1e-3)


@settings(deadline=None, max_examples=50)
@given(st.sampled_from(sorted(FAMILIES)), st.integers(0, 2**31 - 1))
def test_variations_stay_within_mbms_ranges(name, seed):
    """The World draw moves every object rigidly about the robot's base (distances between
    unvaried objects keep); a varied object moves only along its variation's axes, within
    its half-widths, in its own frame."""
    f = FAMILIES[name]
    nominal, poses = f.sample(_Zero()), f.sample(np.random.default_rng(seed))
    varied = {n for v in f.variations for n in v.names}
    fixed = [o.name for o in f.objects if o.name not in varied]
    w = poses[fixed[0]] @ np.linalg.inv(nominal[fixed[0]])  # the World draw
    assert np.all(np.abs(w[:3, 3]) <= f.world.position + 1e-9)
    for n in fixed:
        assert np.allclose(poses[n], w @ nominal[n], atol=1e-9)
    for v in f.variations:
        for n in v.names:
            local = np.linalg.inv(w @ nominal[n]) @ poses[n]
            assert np.all(np.abs(local[:3, 3]) <= v.position + 1e-9)
            assert abs(np.arctan2(local[1, 0], local[0, 0])) <= v.yaw + 1e-9
    yaw = np.arctan2(w[1, 0], w[0, 0])
    assert abs(yaw) <= f.world.yaw + 1e-9 and np.allclose(w[2, :3], [0, 0, 1])


def test_a_seed_gives_the_same_scene():
    f = FAMILIES["table_pick"]
    a, b = f.sample(np.random.default_rng(7)), f.sample(np.random.default_rng(7))
    assert all(np.array_equal(a[k], b[k]) for k in a)
