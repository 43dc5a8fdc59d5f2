"""The depth camera's cloud (mpnet.envs.scenes.camera, env.cloud=camera): rays stop at the nearest
surface, hidden surfaces give no points, and the option is another dataset."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.envs.scenes.camera import POSITION, camera_cloud, depth, rays
from mpnet.envs.shapes import Primitive
from mpnet.envs.workspace import Workspace

AHEAD = np.array([[1.0, 0.0, 0.0]])


@pytest.mark.parametrize(
    "p, expected",
    [
        (Primitive("box", (2, 0, 0), (0.5, 1, 1)), 1.75),
        (Primitive.sphere((2, 0, 0), 0.5), 1.5),
        (Primitive.cylinder((2, 0, 0), 0.5, 1.0), 1.5),  # its side
        (Primitive.cylinder((2, 0, 0), 0.5, 1.0, (0, 0.7071068, 0, 0.7071068)), 1.5),  # lying: its cap
        (Primitive("box", (-2, 0, 0), (0.5, 1, 1)), np.inf),  # behind the camera
        (Primitive("box", (0, 0, 0), (0.5, 1, 1)), np.inf),  # around it: no surface ahead from inside
    ],
)
def test_known_depths(p, expected):
    assert depth([p], np.zeros(3), AHEAD)[0] == pytest.approx(expected)


def _inside(p: Primitive, x: np.ndarray, grow: float = 0.0) -> np.ndarray:
    local = (x - np.asarray(p.center)) @ p.rotation()
    half = np.asarray(p.size) / 2 + grow
    if p.type == "box":
        return np.all(np.abs(local) <= half, axis=1)
    if p.type == "sphere":
        return np.linalg.norm(local, axis=1) <= half[0]
    return (np.hypot(local[:, 0], local[:, 1]) <= half[0]) & (np.abs(local[:, 2]) <= half[2])


@settings(deadline=None, max_examples=40)
@given(
    st.sampled_from(["box", "cylinder", "sphere"]),
    st.lists(st.floats(0.1, 0.6), min_size=3, max_size=3),
    st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1),
    st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3),
)
def test_each_ray_stops_at_the_obstacle_and_never_passes_inside(kind, dims, quat, offset):
    """A hit lies on the obstacle, and a fine march along the ray is outside it before the
    hit (a march may miss a corner the ray grazes; the hit may not miss what the march finds)."""
    size = {"box": dims, "cylinder": [dims[0], dims[0], dims[1]], "sphere": [dims[0]] * 3}[kind]
    p = Primitive(kind, np.array([0.7, 0.0, 0.3]) + offset, size, quat)
    directions = rays(pixels=(24, 20))
    t = depth([p], POSITION, directions)
    steps = np.arange(0.0, 4.0, 0.002)
    some = np.isfinite(t) | (np.arange(len(t)) % 7 == 0)  # every hit, and rays that miss
    for d, ti in zip(directions[some], t[some]):
        inside = _inside(p, POSITION + steps[:, None] * d)
        first = steps[np.argmax(inside)] if inside.any() else np.inf
        assert ti <= first + 1e-9
        if np.isfinite(ti):
            assert _inside(p, (POSITION + ti * d)[None], grow=1e-9)[0] and first >= ti - 0.003


def test_a_hidden_obstacle_gives_no_points():
    front = Primitive("box", (0.6, 0.0, 0.6), (0.05, 3.0, 3.0))  # a wall across the view
    hidden = Primitive.sphere((1.2, 0.0, 0.3), 0.1)
    ws = Workspace("0", "train", np.zeros((0, 3)), np.zeros((0, 3)), (front, hidden))
    cloud = camera_cloud(ws, 500, np.random.default_rng(0))
    assert cloud.shape == (500, 3) and np.allclose(cloud[:, 0], 0.6 - 0.025, atol=1e-9)
    empty = Workspace("1", "train", np.zeros((0, 3)), np.zeros((0, 3)), ())
    assert not camera_cloud(empty, 10, np.random.default_rng(0)).any()


def test_the_camera_is_another_dataset_and_needs_posed_obstacles(settings):
    from harness.core.cli import UsageError

    surface = settings(["+env=panda_mbm", "scale=tiny"])
    camera = settings(["+env=panda_mbm", "scale=tiny", "env.cloud=camera"])
    assert surface.data.key_config() != camera.data.key_config()
    assert camera.env.spec.sample_cloud is camera_cloud
    with pytest.raises(UsageError, match="env.cloud"):
        settings(["+env=s2d", "scale=tiny", "+env.cloud=camera"])
