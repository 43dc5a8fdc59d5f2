"""Inverse kinematics for an arm model (issue 26: MotionBenchMaker's goals are poses of
panda_link8 at the target objects, solved by IK as MBM solves them: random restarts, a
tolerance box and per-axis orientation tolerances, kept only when valid).

Damped least squares on the geometric Jacobian, from the model's own kinematics (numpy; an
IK call is a few hundred small matrix products, and goals are made once per query, so no
compiled code). Why not a library: KDL (MBM's solver) has no maintained PyPI wheel, and
the packaged IK solvers (ikpy, pinocchio) would bring their own URDF reading, not the model's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from mpnet.envs.arm_model import PRISMATIC, ArmModel


@dataclass(frozen=True)
class IKTarget:
    """A pose for `link` in the base frame (4 x 4), met when the position lies in the box
    of full size position_tol around it (base-frame axes, as MBM's region) and the rotation
    from the wanted orientation to the link's is within orientation_tol about each of the
    wanted frame's axes (MoveIt's absolute axis tolerances)."""

    link: str
    pose: np.ndarray
    position_tol: np.ndarray
    orientation_tol: np.ndarray


def _frames(model: ArmModel, link: str) -> tuple[int, list[int]]:
    kin = model.kinematics
    tip = kin.index(link)
    joints, i = [], tip
    while i >= 0:
        if kin.frames[i].coordinate >= 0:
            joints.append(i)
        i = kin.frames[i].parent
    return tip, joints[::-1]


def jacobian(model: ArmModel, q: np.ndarray, link: str) -> tuple[np.ndarray, np.ndarray]:
    """(link's 4 x 4 pose, 6 x dof geometric Jacobian: linear rows first, base frame)."""
    return _jacobian(model, q, *_frames(model, link))


def _jacobian(model: ArmModel, q: np.ndarray, tip: int, joints: list[int]) -> tuple[np.ndarray, np.ndarray]:
    kin = model.kinematics
    T = kin.link_transforms(q)
    p = T[tip, :3, 3]
    J = np.zeros((6, model.dof))
    for i in joints:
        f = kin.frames[i]
        axis = T[i, :3, :3] @ f.axis
        if f.kind == PRISMATIC:
            J[:3, f.coordinate] = axis
        else:
            J[:3, f.coordinate] = np.cross(axis, p - T[i, :3, 3])
            J[3:, f.coordinate] = axis
    return T[tip], J


def meets(model: ArmModel, q: np.ndarray, target: IKTarget) -> bool:
    """Does q put the target's link within its tolerances?"""
    T = model.link_transforms(q)[model.kinematics.index(target.link)]
    if np.any(np.abs(T[:3, 3] - target.pose[:3, 3]) > target.position_tol / 2 + 1e-12):
        return False
    err = Rotation.from_matrix(target.pose[:3, :3].T @ T[:3, :3]).as_rotvec()
    return bool(np.all(np.abs(err) <= target.orientation_tol + 1e-12))


def solve(
    model: ArmModel,
    target: IKTarget,
    rng: np.random.Generator,
    *,
    seed_q: np.ndarray | None = None,
    attempts: int = 200,
    iterations: int = 100,
    valid=None,
    damping: float = 0.05,
) -> np.ndarray | None:
    """A joint vector within the model's limits that meets `target` and that `valid(q)`
    accepts, or None after `attempts` starts: the first from seed_q (if given), the others
    uniform within the limits (MBM: 200 attempts, random restarts). Each attempt aims at a
    pose drawn within the tolerances, as MBM's IK query does."""
    lower = np.array([b[0] for b in model.limits])
    upper = np.array([b[1] for b in model.limits])
    chain = _frames(model, target.link)  # once: every iteration walks the same chain
    for k in range(attempts):
        q = np.array(seed_q, float) if (k == 0 and seed_q is not None) else rng.uniform(lower, upper)
        aim = target.pose.copy()
        aim[:3, 3] += rng.uniform(-target.position_tol / 2, target.position_tol / 2)
        aim[:3, :3] = aim[:3, :3] @ Rotation.from_rotvec(rng.uniform(-1, 1, 3) * target.orientation_tol).as_matrix()
        for _ in range(iterations):
            T, J = _jacobian(model, q, *chain)
            e = np.concatenate([aim[:3, 3] - T[:3, 3], Rotation.from_matrix(aim[:3, :3] @ T[:3, :3].T).as_rotvec()])
            if np.linalg.norm(e) < 1e-6:
                break
            dq = J.T @ np.linalg.solve(J @ J.T + damping**2 * np.eye(6), e)
            q = np.clip(q + dq, lower, upper)
        if meets(model, q, target) and (valid is None or valid(q)):
            return q
    return None
