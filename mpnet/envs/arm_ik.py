"""Inverse kinematics for an arm model (issue 26: MotionBenchMaker's goals are poses of
panda_link8 at the target objects, solved by IK as MBM solves them: random restarts, a
tolerance box and per-axis orientation tolerances, kept only when valid).

Damped least squares on the geometric Jacobian, from the model's own kinematics (numpy, the
restarts batched as arrays: a failed 200-restart call takes ~0.2 s, not seconds, which is what
generating thousands of scenes needs). Why not a library: KDL (MBM's solver) has no maintained PyPI wheel, and
the packaged IK solvers (ikpy, pinocchio) would bring their own URDF reading, not the model's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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
    from scipy.spatial.transform import Rotation  # here: see solve

    T = model.link_transforms(q)[model.kinematics.index(target.link)]
    if np.any(np.abs(T[:3, 3] - target.pose[:3, 3]) > target.position_tol / 2 + 1e-12):
        return False
    err = Rotation.from_matrix(target.pose[:3, :3].T @ T[:3, :3]).as_rotvec()
    return bool(np.all(np.abs(err) <= target.orientation_tol + 1e-12))


def _path(model: ArmModel, link: str) -> list[int]:
    """Frame indices from the root to `link`."""
    kin = model.kinematics
    i, out = kin.index(link), []
    while i >= 0:
        out.append(i)
        i = kin.frames[i].parent
    return out[::-1]


def _batch_jacobian(model: ArmModel, Q: np.ndarray, path: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """(B x 4 x 4 poses, B x 6 x dof Jacobians) of the path's last frame for B joint vectors:
    the chain walked once for all of them (IK's restarts run side by side)."""
    kin = model.kinematics
    B = len(Q)
    T = np.broadcast_to(np.eye(4), (B, 4, 4)).copy()
    axes, origins, kinds, coords = [], [], [], []
    for i in path:
        f = kin.frames[i]
        T = T @ f.origin
        if f.coordinate < 0:
            continue
        v = Q[:, f.coordinate]
        m = np.broadcast_to(np.eye(4), (B, 4, 4)).copy()
        if f.kind == PRISMATIC:
            m[:, :3, 3] = v[:, None] * f.axis
        else:
            x, y, z = f.axis
            K = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
            m[:, :3, :3] += np.sin(v)[:, None, None] * K + (1 - np.cos(v))[:, None, None] * (K @ K)
        axes.append(T[:, :3, :3] @ f.axis)
        origins.append(T[:, :3, 3].copy())
        kinds.append(f.kind)
        coords.append(f.coordinate)
        T = T @ m
    J = np.zeros((B, 6, model.dof))
    p = T[:, :3, 3]
    for axis, origin, kind, c in zip(axes, origins, kinds, coords):
        if kind == PRISMATIC:
            J[:, :3, c] = axis
        else:
            J[:, :3, c] = np.cross(axis, p - origin)
            J[:, 3:, c] = axis
    return T, J


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
    batch: int = 25,
) -> np.ndarray | None:
    """A joint vector within the model's limits that meets `target` and that `valid(q)`
    accepts, or None after `attempts` starts: the first from seed_q (if given), the others
    uniform within the limits (MBM: 200 attempts, random restarts). Each attempt aims at a
    pose drawn within the tolerances, as MBM's IK query does. The first `batch` attempts run
    side by side as arrays, then all the rest; the first success in attempt order is returned."""
    # Imported where IK runs: scipy.spatial costs ~0.25 s, and every process that imports
    # mpnet.envs (a run's, its log process) would pay it for IK that only data building does.
    from scipy.spatial.transform import Rotation

    lower = np.array([b[0] for b in model.limits])
    upper = np.array([b[1] for b in model.limits])
    path = _path(model, target.link)
    for first in (0, batch) if attempts > batch else (0,):
        B = min(batch, attempts) if first == 0 else attempts - batch
        Q = rng.uniform(lower, upper, size=(B, model.dof))
        if first == 0 and seed_q is not None:
            Q[0] = seed_q
        aim_p = target.pose[:3, 3] + rng.uniform(-target.position_tol / 2, target.position_tol / 2, size=(B, 3))
        turn = Rotation.from_rotvec(rng.uniform(-1, 1, (B, 3)) * target.orientation_tol).as_matrix()
        aim_R = target.pose[:3, :3] @ turn
        eye = damping**2 * np.eye(6)
        for _ in range(iterations):
            T, J = _batch_jacobian(model, Q, path)
            e = np.concatenate(
                [aim_p - T[:, :3, 3], Rotation.from_matrix(aim_R @ T[:, :3, :3].transpose(0, 2, 1)).as_rotvec()],
                axis=1,
            )
            moving = np.linalg.norm(e, axis=1) >= 1e-6
            if not moving.any():
                break
            Jt = J.transpose(0, 2, 1)
            dq = (Jt @ np.linalg.solve(J @ Jt + eye, e[:, :, None]))[:, :, 0]
            Q = np.where(moving[:, None], np.clip(Q + dq, lower, upper), Q)
        for q in Q:
            if meets(model, q, target) and (valid is None or valid(q)):
                return q
    return None
