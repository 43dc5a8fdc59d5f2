"""Compiled damped-least-squares IK for one restart (mpnet.envs.arm.ik.solve's inner loop).

Why compiled: the MBM-style queries of panda_mbm's data are goals found by IK, 200 restarts
of up to 100 iterations each; as numpy arrays over the restarts, IK was most of the expert's
time (a profile of 14 scenes: 98 of 166 CPU-s, the planning itself 67). Here each restart runs
alone, in attempt order, so the first restart that meets the target ends the call without
solving the others; each restart's iterates are the batched version's (each restart's
update never read another's), up to floating-point rounding. A restart's iterations allocate
nothing and count no references (mpnet.jit's borrowed: the pose, rotation vector and solve
write scratch that dls allocates once), the same arithmetic in the same order.

A chain is mpnet.envs.arm.kinematics.forward's arrays for the frames on the path from the base
to the tip, each driven joint as two frames: its fixed origin, then its motion (an identity
origin): arm.ik.chain_arrays. The tip is the last frame; a driven joint's axis and origin in the
base frame are read from its first frame's pose.
"""

from __future__ import annotations

import math

import numpy as np

from mpnet.envs.arm.kinematics import PRISMATIC, forward
from mpnet.jit import njit


@njit(cache=True)
def rotvec(R: np.ndarray) -> np.ndarray:
    """The rotation vector of a 3 x 3 rotation matrix, as scipy's Rotation computes it: the
    matrix's quaternion by the largest of its trace and diagonal, scalar part made >= 0, then
    angle 2 atan2(|xyz|, w) about xyz."""
    out = np.empty(3)
    _rotvec_into(R, np.empty(4), out)
    return out


@njit(cache=True, borrowed=True)
def _rotvec_into(R, q, out):
    """rotvec(R) into out (q: scratch of 4, the quaternion x, y, z, w)."""
    t = R[0, 0] + R[1, 1] + R[2, 2]
    k, best = 0, R[0, 0]  # argmax of (R00, R11, R22, trace), the first of equals
    for i in range(1, 3):
        if R[i, i] > best:
            best, k = R[i, i], i
    if t > best:
        k = 3
    if k == 3:
        q[3] = 1.0 + t
        q[0] = R[2, 1] - R[1, 2]
        q[1] = R[0, 2] - R[2, 0]
        q[2] = R[1, 0] - R[0, 1]
    else:
        i, j, m = k, (k + 1) % 3, (k + 2) % 3
        q[i] = 1.0 - t + 2.0 * R[i, i]
        q[j] = R[j, i] + R[i, j]
        q[m] = R[m, i] + R[i, m]
        q[3] = R[m, j] - R[j, m]
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        q[i] /= n
    if q[3] < 0:
        for i in range(4):
            q[i] = -q[i]
    s = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2])
    angle = 2.0 * math.atan2(s, q[3])
    if angle <= 1e-3:
        a2 = angle * angle
        scale = 2.0 + a2 / 12.0 + 7.0 * a2 * a2 / 2880.0
    else:
        scale = angle / math.sin(angle / 2.0)
    for i in range(3):
        out[i] = scale * q[i]


@njit(cache=True)
def chain_pose(q, parent, origin, kind, axis, coord) -> np.ndarray:
    """The tip's 4 x 4 pose at q (a chain's arrays: see the module)."""
    pose = np.empty((parent.shape[0] + 1, 3, 4))
    forward(q, parent, origin, kind, axis, coord, pose)
    T = np.empty((4, 4))
    _tip(pose, parent.shape[0] - 1, T)
    return T


@njit(cache=True, borrowed=True)
def _tip(pose, tip, T):
    """T (4 x 4) = frame tip's pose."""
    for r in range(3):
        for c in range(4):
            T[r, c] = pose[tip, r, c]
    T[3, 0], T[3, 1], T[3, 2], T[3, 3] = 0.0, 0.0, 0.0, 1.0


@njit(cache=True, borrowed=True)
def _spd_solve6(A, b, L, y):
    """Solve A x = b in place of b for a 6 x 6 symmetric positive definite A (Cholesky; the
    damped normal matrix J J^T + damping^2 I always is). L, y: scratch."""
    for i in range(6):
        for j in range(i + 1):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = math.sqrt(s) if i == j else s / L[j, j]
    for i in range(6):
        s = b[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]
    for i in range(5, -1, -1):
        s = y[i]
        for k in range(i + 1, 6):
            s -= L[k, i] * b[k]
        b[i] = s / L[i, i]


@njit(cache=True)
def dls(q0, aim_p, aim_R, lower, upper, parent, origin, kind, axis, coord, iterations, damping):
    """One restart of damped least squares from q0 toward (aim_p, aim_R) on a chain (see the
    module): up to `iterations` steps dq = J^T (J J^T + damping^2 I)^-1 e, clipped to the
    limits, stopping once the error's norm is under 1e-6. Returns (q, the tip's pose at q)."""
    q = q0.copy()
    n = parent.shape[0]
    T = np.empty((4, 4))
    _dls_into(q, aim_p, aim_R, lower, upper, parent, origin, kind, axis, coord, iterations, damping, T,
              np.zeros((n + 1, 3, 4)), np.zeros((6, q.shape[0])), np.empty(6), np.empty((6, 6)), np.zeros((6, 6)),
              np.empty(6), np.empty((3, 3)), np.empty(4), np.empty(3))  # fmt: skip
    return q, T


@njit(cache=True, borrowed=True)
def _dls_into(q, aim_p, aim_R, lower, upper, parent, origin, kind, axis, coord, iterations, damping, T,
              pose, J, e, A, L, y, R, quat, rv):  # fmt: skip
    """dls's iterations on q in place, the tip's pose into T; the rest: scratch (allocated
    once a restart by dls, so the iterations allocate nothing and count no references)."""
    dof = q.shape[0]
    n = parent.shape[0]
    tip = n - 1
    lam = damping * damping
    forward(q, parent, origin, kind, axis, coord, pose)
    for _ in range(iterations):
        for i in range(3):
            e[i] = aim_p[i] - pose[tip, i, 3]
        for r in range(3):  # aim_R @ T_R^T
            for c in range(3):
                R[r, c] = aim_R[r, 0] * pose[tip, c, 0] + aim_R[r, 1] * pose[tip, c, 1] + aim_R[r, 2] * pose[tip, c, 2]
        _rotvec_into(R, quat, rv)
        e[3], e[4], e[5] = rv[0], rv[1], rv[2]
        s = 0.0  # np.sum(e * e), term by term in the same order
        for i in range(6):
            s += e[i] * e[i]
        if math.sqrt(s) < 1e-6:
            break
        J[:] = 0.0
        for f in range(n):
            c = coord[f]
            if c < 0:
                continue
            b, x, y_, z = parent[f], axis[f, 0], axis[f, 1], axis[f, 2]  # the joint's fixed frame, its axis
            a0 = pose[b, 0, 0] * x + pose[b, 0, 1] * y_ + pose[b, 0, 2] * z
            a1 = pose[b, 1, 0] * x + pose[b, 1, 1] * y_ + pose[b, 1, 2] * z
            a2 = pose[b, 2, 0] * x + pose[b, 2, 1] * y_ + pose[b, 2, 2] * z
            if kind[f] == PRISMATIC:
                J[0, c], J[1, c], J[2, c] = a0, a1, a2
            else:
                d0 = pose[tip, 0, 3] - pose[b, 0, 3]
                d1 = pose[tip, 1, 3] - pose[b, 1, 3]
                d2 = pose[tip, 2, 3] - pose[b, 2, 3]
                J[0, c] = a1 * d2 - a2 * d1
                J[1, c] = a2 * d0 - a0 * d2
                J[2, c] = a0 * d1 - a1 * d0
                J[3, c], J[4, c], J[5, c] = a0, a1, a2
        for i in range(6):
            for j in range(i + 1):
                s = lam if i == j else 0.0
                for k in range(dof):
                    s += J[i, k] * J[j, k]
                A[i, j] = s
                A[j, i] = s
        _spd_solve6(A, e, L, y)  # e <- (J J^T + lam I)^-1 e
        for k in range(dof):
            s = 0.0
            for i in range(6):
                s += J[i, k] * e[i]
            q[k] = min(max(q[k] + s, lower[k]), upper[k])
        forward(q, parent, origin, kind, axis, coord, pose)
    _tip(pose, tip, T)


@njit(cache=True)
def meets_pose(T, pose, position_tol, orientation_tol) -> bool:
    """Does the tip's pose T lie within the target's position box and per-axis orientation
    tolerances (arm.ik.IKTarget)?"""
    for i in range(3):
        if abs(T[i, 3] - pose[i, 3]) > position_tol[i] / 2 + 1e-12:
            return False
    R = np.empty((3, 3))  # pose_R^T @ T_R
    for r in range(3):
        for c in range(3):
            R[r, c] = pose[0, r] * T[0, c] + pose[1, r] * T[1, c] + pose[2, r] * T[2, c]
    err = rotvec(R)
    for i in range(3):
        if abs(err[i]) > orientation_tol[i] + 1e-12:
            return False
    return True
