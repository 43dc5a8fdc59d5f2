"""Inverse kinematics for an arm model (issue 26: MotionBenchMaker's goals are poses of
panda_link8 at the target objects, solved by IK as MBM solves them: random restarts, a
tolerance box and per-axis orientation tolerances, kept only when valid).

Damped least squares on the geometric Jacobian, from the model's own kinematics, compiled
(mpnet/envs/arm/ik_kernels.py: one restart at a time, in attempt order, until one succeeds).
Why not a library: KDL (MBM's solver) has no maintained PyPI wheel, and the packaged IK
solvers (ikpy, pinocchio) would bring their own URDF reading, not the model's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpnet.envs.arm import kinematics
from mpnet.envs.arm.ik_kernels import dls, meets_pose
from mpnet.envs.arm.model import FIXED, PRISMATIC, REVOLUTE, ArmModel

assert (kinematics.FIXED, kinematics.REVOLUTE, kinematics.PRISMATIC) == (FIXED, REVOLUTE, PRISMATIC)


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


def chain_arrays(model: ArmModel, link: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The frames from the base to `link` as ik_kernels' chain: kinematics.forward's arrays
    (parent, origin (n x 3 x 4), kind, axis (n x 3), coordinate), each driven joint split into
    its fixed origin and then its motion (about an identity origin), so that a pose is
    (parent's pose times origin) times motion, the order IK's poses have always been
    multiplied in (the sphere checker's, a whole tree's, is parent's times (origin times motion))."""
    frames = [model.kinematics.frames[i] for i in _path(model, link)]
    if not all((f.origin[3] == [0.0, 0.0, 0.0, 1.0]).all() for f in frames):  # forward takes 3 x 4 origins
        raise ValueError(f"{link}: a frame origin whose last row is not 0 0 0 1")
    parent, origin, kind, axis, coord = [], [], [], [], []
    for f in frames:
        parts = [(f.origin[:3], FIXED, np.zeros(3), -1)]
        if f.coordinate >= 0:
            parts.append((np.eye(4)[:3], f.kind, f.axis, f.coordinate))
        for o, k, a, c in parts:
            parent.append(len(parent) - 1)
            origin.append(o)
            kind.append(k)
            axis.append(a)
            coord.append(c)
    return (
        np.array(parent, np.int64),
        np.ascontiguousarray(np.array(origin, float)),
        np.array(kind, np.int64),
        np.array(axis, float),
        np.array(coord, np.int64),
    )


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
    pose drawn within the tolerances, as MBM's IK query does. The attempts are drawn `batch`
    at a time (the first `batch`, then all the rest) and solved one by one in attempt order
    (ik_kernels.dls); the first that succeeds is returned."""
    # Imported where IK runs: scipy.spatial costs ~0.25 s, and every process that imports
    # mpnet.envs (a run's, its log process) would pay it for IK that only data building does.
    from scipy.spatial.transform import Rotation

    lower = np.array([b[0] for b in model.limits])
    upper = np.array([b[1] for b in model.limits])
    chain = chain_arrays(model, target.link)
    pose = np.ascontiguousarray(target.pose, float)
    ptol, otol = np.asarray(target.position_tol, float), np.asarray(target.orientation_tol, float)
    for first in (0, batch) if attempts > batch else (0,):
        B = min(batch, attempts) if first == 0 else attempts - batch
        Q = rng.uniform(lower, upper, size=(B, model.dof))
        if first == 0 and seed_q is not None:
            Q[0] = seed_q
        aim_p = target.pose[:3, 3] + rng.uniform(-target.position_tol / 2, target.position_tol / 2, size=(B, 3))
        turn = Rotation.from_rotvec(rng.uniform(-1, 1, (B, 3)) * target.orientation_tol).as_matrix()
        aim_R = target.pose[:3, :3] @ turn
        for b in range(B):
            q, T = dls(Q[b], aim_p[b], aim_R[b], lower, upper, *chain, iterations, damping)
            if meets_pose(T, pose, ptol, otol) and (valid is None or valid(q)):
                return q
    return None
