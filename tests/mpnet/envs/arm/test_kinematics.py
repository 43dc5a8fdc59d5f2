"""The arm's one forward kinematics and joint rotation (mpnet.envs.arm.kinematics): known
answers, the arithmetic the copies it replaced had (bit for bit), and the split chain inverse
kinematics poses."""

from __future__ import annotations

import math

import numpy as np

from mpnet.envs.arm import ik_kernels
from mpnet.envs.arm.ik import chain_arrays
from mpnet.envs.arm.kinematics import FIXED, PRISMATIC, REVOLUTE, forward, joint_rotation
from mpnet.envs.arm.model import joint_motion, load_arm_model

MODEL = load_arm_model("panda")


def _rodrigues(x: float, y: float, z: float, v: float) -> list[list[float]]:
    """arm.model.joint_motion's rotation as it was written in Python floats (and sphere_kernels'
    and ik_kernels' inlined copies), in its order."""
    c, s = math.cos(v), math.sin(v)
    C = 1 - c
    return [
        [c + x * x * C, x * y * C - z * s, x * z * C + y * s],
        [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
        [z * x * C - y * s, z * y * C + x * s, c + z * z * C],
    ]


def test_a_quarter_turn_about_z_takes_x_to_y():
    R = np.reshape(joint_rotation(0.0, 0.0, 1.0, math.pi / 2), (3, 3))
    assert np.allclose(R @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)
    assert np.allclose(R @ [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], atol=1e-15)


def test_the_joint_rotation_is_the_python_formulas_bit_for_bit_and_a_rotation():
    rng = np.random.default_rng(0)
    for _ in range(500):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        x, y, z = (float(a) for a in axis)
        v = float(rng.uniform(-4.0, 4.0))
        R = np.reshape(joint_rotation(x, y, z, v), (3, 3))
        assert np.array_equal(R, np.array(_rodrigues(x, y, z, v)))
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-12) and np.allclose(R @ axis, axis, atol=1e-12)
        m = joint_motion(REVOLUTE, axis, v)  # the model's 4 x 4 (held revolute joints) is the same rotation
        assert np.array_equal(m[:3, :3], R) and np.array_equal(m[:3, 3], np.zeros(3))
    assert np.array_equal(joint_motion(PRISMATIC, np.array([0.0, 0.6, 0.8]), 2.0)[:3, 3], [0.0, 1.2, 1.6])


def test_forward_poses_a_two_joint_arm_as_by_hand():
    """A revolute joint about z at the base, a link of length 1 along x, a prismatic joint along x."""
    parent = np.array([-1, 0, 1], np.int64)
    origin = np.zeros((3, 3, 4))
    origin[:, :, :3] = np.eye(3)
    origin[2, 0, 3] = 1.0
    kind, coord = np.array([REVOLUTE, FIXED, PRISMATIC], np.int64), np.array([0, -1, 1], np.int64)
    axis = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    out = np.zeros((4, 3, 4))
    forward(np.array([math.pi / 2, 0.5]), parent, origin, kind, axis, coord, out)
    assert np.allclose(out[2, :, 3], [0.0, 1.5, 0.0], atol=1e-15)  # 1 + 0.5 along x, turned onto y
    assert np.allclose(out[2, :, :3], [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], atol=1e-15)


def test_the_split_chain_poses_the_tip_as_the_tree_does():
    """IK's chain (each joint split into its origin and its motion) poses panda_link8 where the
    whole tree puts it, up to the rounding of the other multiplication order."""
    chain = chain_arrays(MODEL, "panda_link8")
    assert len(chain[0]) == len([f for f in chain[4] if f >= 0]) + 9  # 7 joints split; base, links 1-7, link8
    tip = MODEL.kinematics.index("panda_link8")
    rng = np.random.default_rng(2)
    lower, upper = np.array(MODEL.limits).T
    for _ in range(50):
        q = rng.uniform(lower, upper)
        assert np.allclose(ik_kernels.chain_pose(q, *chain), MODEL.link_transforms(q)[tip], atol=1e-12)
