"""Inverse kinematics on the arm model (mpnet.envs.arm.ik): the Jacobian matches finite
differences, and poses the arm can reach are reached within MBM-like tolerances."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from mpnet.envs.arm import ik_kernels
from mpnet.envs.arm.ik import IKTarget, chain_arrays, jacobian, meets, solve
from mpnet.envs.arm.model import load_arm_model

MODEL = load_arm_model("panda")
LOWER = np.array([b[0] for b in MODEL.limits])
UPPER = np.array([b[1] for b in MODEL.limits])


@settings(deadline=None, max_examples=30)
@given(st.integers(0, 2**31 - 1))
def test_jacobian_matches_finite_differences(seed):
    q = np.random.default_rng(seed).uniform(LOWER, UPPER)
    T, J = jacobian(MODEL, q, "panda_link8")
    h = 1e-6
    for j in range(MODEL.dof):
        dq = np.zeros(MODEL.dof)
        dq[j] = h
        T2 = MODEL.link_transforms(q + dq)[MODEL.kinematics.index("panda_link8")]
        assert np.allclose((T2[:3, 3] - T[:3, 3]) / h, J[:3, j], atol=1e-5)
        w = Rotation.from_matrix(T2[:3, :3] @ T[:3, :3].T).as_rotvec() / h
        assert np.allclose(w, J[3:, j], atol=1e-5)


@settings(deadline=None, max_examples=20)
@given(st.integers(0, 2**31 - 1))
def test_a_reachable_pose_is_reached_within_tolerance(seed):
    """A pose of a configuration 5% of each joint's range inside its limits: the solver's random
    restarts reach poses made right at the limits only rarely (seed 193992: 200 attempts, not
    50), and MBM's grasp poses are not made there."""
    rng = np.random.default_rng(seed)
    margin = 0.05 * (UPPER - LOWER)
    q0 = rng.uniform(LOWER + margin, UPPER - margin)
    pose = MODEL.link_transforms(q0)[MODEL.kinematics.index("panda_link8")]
    target = IKTarget("panda_link8", pose, np.full(3, 0.01), np.full(3, 0.01))
    q = solve(MODEL, target, rng, attempts=50)
    assert q is not None and meets(MODEL, q, target)
    assert np.all(q >= LOWER) and np.all(q <= UPPER)


def test_an_unreachable_pose_gives_none():
    far = np.eye(4)
    far[:3, 3] = [3.0, 0.0, 0.5]
    target = IKTarget("panda_link8", far, np.full(3, 0.01), np.full(3, 0.01))
    assert solve(MODEL, target, np.random.default_rng(0), attempts=5) is None


def test_valid_rejects_solutions():
    rng = np.random.default_rng(1)
    pose = MODEL.link_transforms(rng.uniform(LOWER, UPPER))[MODEL.kinematics.index("panda_link8")]
    target = IKTarget("panda_link8", pose, np.full(3, 0.01), np.full(3, 0.01))
    assert solve(MODEL, target, rng, attempts=5, valid=lambda q: False) is None


def _rotations():
    """Random rotations, and the ones a rotation vector is delicate at: none, tiny, near pi."""
    yield np.eye(3)
    for v in ([1e-9, 0, 0], [0, 2e-4, -1e-4], [np.pi - 1e-9, 0, 0], [0, 0, np.pi], [1.0, 1.0, 1.0]):
        yield Rotation.from_rotvec(v).as_matrix()
    yield from Rotation.random(200, random_state=3).as_matrix()


def test_compiled_rotation_vector_is_scipys():
    for R in _rotations():
        ours, theirs = ik_kernels.rotvec(np.ascontiguousarray(R)), Rotation.from_matrix(R).as_rotvec()
        assert np.allclose(ours, theirs, atol=1e-9) or np.isclose(np.linalg.norm(theirs), np.pi)
        # at pi, v and -v are the same rotation
        assert np.allclose(Rotation.from_rotvec(ours).as_matrix(), R, atol=1e-9)


@settings(deadline=None, max_examples=30)
@given(st.integers(0, 2**31 - 1))
def test_compiled_chain_pose_and_tolerance_are_the_models(seed):
    """The kernel's tip pose is the model's link_transforms; its tolerance test is meets'."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(LOWER, UPPER)
    T = ik_kernels.chain_pose(q, *chain_arrays(MODEL, "panda_link8"))
    assert np.allclose(T, MODEL.link_transforms(q)[MODEL.kinematics.index("panda_link8")], atol=1e-12)
    pose = MODEL.link_transforms(rng.uniform(LOWER, UPPER))[MODEL.kinematics.index("panda_link8")]
    pose[:3, 3] = T[:3, 3] + rng.uniform(-0.01, 0.01, 3)
    target = IKTarget("panda_link8", pose, np.full(3, 0.012), np.full(3, rng.uniform(0.1, 3.2)))
    assert ik_kernels.meets_pose(T, pose, target.position_tol, target.orientation_tol) == meets(MODEL, q, target)


def test_the_first_restart_that_succeeds_is_returned_and_later_ones_are_not_solved():
    """Attempt order decides: from a seed that meets the target, the first attempt (aimed at a
    pose drawn within the tolerances, a small step away) succeeds and no other is solved."""
    rng = np.random.default_rng(5)
    q0 = rng.uniform(LOWER, UPPER)
    pose = MODEL.link_transforms(q0)[MODEL.kinematics.index("panda_link8")]
    target = IKTarget("panda_link8", pose, np.full(3, 0.01), np.full(3, 0.01))
    calls = []
    q = solve(MODEL, target, rng, seed_q=q0, attempts=200, valid=lambda q: calls.append(q) or True)
    assert len(calls) == 1 and np.abs(q - q0).max() < 0.05


def test_a_restart_iterates_as_before_the_scratch():
    """dls's iterations write scratch instead of allocating (borrowed kernels), and pose the chain
    with the one forward kinematics (its joints split: chain_arrays): the same joint vectors and
    poses, bit for bit, as the allocating kernel with a chain product of its own gave (recorded
    at 2424fa5)."""
    import hashlib

    chain = chain_arrays(MODEL, "panda_link8")
    rng = np.random.default_rng(42)
    h = hashlib.sha256()
    for _ in range(200):
        qt, q0 = rng.uniform(LOWER, UPPER), rng.uniform(LOWER, UPPER)
        T = ik_kernels.chain_pose(qt, *chain)
        aim_p, aim_R = T[:3, 3] + rng.uniform(-0.01, 0.01, 3), np.ascontiguousarray(T[:3, :3])
        q, T2 = ik_kernels.dls(q0, aim_p, aim_R, LOWER, UPPER, *chain, 100, 0.05)
        h.update(q.tobytes() + T2.tobytes())
    assert h.hexdigest()[:16] == "865156361e8cc190"


def test_a_chain_whose_origin_is_not_rigid_is_refused():
    """The kernels keep a pose's last row 0 0 0 1 without computing it: chain_arrays refuses a
    frame origin that would change it, naming the link."""
    import copy

    model = copy.deepcopy(MODEL)
    frame = model.kinematics.frames[model.kinematics.index("panda_link3")]
    frame.origin[3, 0] = 1e-9
    with pytest.raises(ValueError, match="panda_link8: a frame origin whose last row"):
        chain_arrays(model, "panda_link8")
