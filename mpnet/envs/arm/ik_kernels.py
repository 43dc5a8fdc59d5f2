"""Compiled damped-least-squares IK for one restart (mpnet.envs.arm.ik.solve's inner loop).

Why compiled: the MBM-style queries of panda_mbm's data are goals found by IK, 200 restarts
of up to 100 iterations each; as numpy arrays over the restarts, IK was most of the expert's
time (a profile of 14 scenes: 98 of 166 CPU-s, the planning itself 67). Here each restart runs
alone, in attempt order, so the first restart that meets the target ends the call without
solving the others; each restart's iterates are the batched version's (each restart's
update never read another's), up to floating-point rounding. A restart's iterations allocate
nothing and count no references (mpnet.jit's borrowed: the pose, rotation vector and solve
write scratch that dls allocates once), the same arithmetic in the same order.

A chain is arrays: per frame on the path from the base to the tip, its fixed origin (4 x 4),
the planned coordinate that drives it (-1: none), its kind (arm_model's REVOLUTE/PRISMATIC)
and its axis.
"""

from __future__ import annotations

import math

import numpy as np

from mpnet.jit import njit

REVOLUTE, PRISMATIC = 1, 2  # arm.model's joint kinds (asserted equal in arm.ik)


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


@njit(cache=True, borrowed=True, inline="always")
def _times(T, B):
    """T = T @ B for 4 x 4 transforms, rows 0-2 in place (the last row of both is 0 0 0 1,
    so T's stays so)."""
    for r in range(3):
        t0, t1, t2, t3 = T[r, 0], T[r, 1], T[r, 2], T[r, 3]
        for c in range(4):
            T[r, c] = t0 * B[0, c] + t1 * B[1, c] + t2 * B[2, c] + t3 * B[3, c]


@njit(cache=True)
def chain_pose(q, origins, coords, kinds, axes, joint_axes, joint_origins) -> np.ndarray:
    """The tip's 4 x 4 pose at q; fills each driven frame's world axis and origin (rows in
    chain order, the rest untouched)."""
    T = np.empty((4, 4))
    _chain_pose_into(q, origins, coords, kinds, axes, joint_axes, joint_origins, T, np.empty((4, 4)))
    return T


@njit(cache=True, borrowed=True)
def _eye4(m):
    for r in range(4):
        for c in range(4):
            m[r, c] = 1.0 if r == c else 0.0


@njit(cache=True, borrowed=True)
def _chain_pose_into(q, origins, coords, kinds, axes, joint_axes, joint_origins, T, m):
    """chain_pose into T (m: 4 x 4 scratch), multiplied in place (_times: every origin's last
    row is 0 0 0 1, chain_arrays checks, and every joint's transform's is). A joint about z
    skips its rotation's zero terms: bit for bit the numbers of the general product (as
    sphere_kernels.forward does): a pose 564 -> 254 ns."""
    _eye4(T)
    _eye4(m)
    for f in range(origins.shape[0]):
        _times(T, origins[f])
        c = coords[f]
        if c < 0:
            continue
        x, y, z = axes[f, 0], axes[f, 1], axes[f, 2]
        for r in range(3):
            joint_axes[f, r] = T[r, 0] * x + T[r, 1] * y + T[r, 2] * z
            joint_origins[f, r] = T[r, 3]
        v = q[c]
        if kinds[f] != PRISMATIC and x == 0.0 and y == 0.0 and z == 1.0:
            co, si = math.cos(v), math.sin(v)
            m22 = co + (1.0 - co)
            for r in range(3):
                t0, t1 = T[r, 0], T[r, 1]
                T[r, 0] = t0 * co + t1 * si
                T[r, 1] = t0 * -si + t1 * co
                T[r, 2] = T[r, 2] * m22
            continue
        if kinds[f] == PRISMATIC:
            for r in range(3):
                for s in range(3):
                    m[r, s] = 1.0 if r == s else 0.0
            m[0, 3], m[1, 3], m[2, 3] = v * x, v * y, v * z
        else:
            co, si = math.cos(v), math.sin(v)
            C = 1.0 - co
            m[0, 0], m[0, 1], m[0, 2] = co + x * x * C, x * y * C - z * si, x * z * C + y * si
            m[1, 0], m[1, 1], m[1, 2] = y * x * C + z * si, co + y * y * C, y * z * C - x * si
            m[2, 0], m[2, 1], m[2, 2] = z * x * C - y * si, z * y * C + x * si, co + z * z * C
            m[0, 3], m[1, 3], m[2, 3] = 0.0, 0.0, 0.0
        _times(T, m)


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
def dls(q0, aim_p, aim_R, lower, upper, origins, coords, kinds, axes, iterations, damping):
    """One restart of damped least squares from q0 toward (aim_p, aim_R): up to `iterations`
    steps dq = J^T (J J^T + damping^2 I)^-1 e, clipped to the limits, stopping once the
    error's norm is under 1e-6. Returns (q, the tip's pose at q)."""
    q = q0.copy()
    n = origins.shape[0]
    T = np.empty((4, 4))
    _dls_into(q, aim_p, aim_R, lower, upper, origins, coords, kinds, axes, iterations, damping, T,
              np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((6, q.shape[0])), np.empty(6), np.empty((6, 6)),
              np.zeros((6, 6)), np.empty(6), np.empty((3, 3)), np.empty((4, 4)), np.empty(4),
              np.empty(3))  # fmt: skip
    return q, T


@njit(cache=True, borrowed=True)
def _dls_into(q, aim_p, aim_R, lower, upper, origins, coords, kinds, axes, iterations, damping, T,
              joint_axes, joint_origins, J, e, A, L, y, R, m, quat, rv):  # fmt: skip
    """dls's iterations on q in place, the tip's pose into T; the rest: scratch (allocated
    once a restart by dls, so the iterations allocate nothing and count no references)."""
    dof = q.shape[0]
    n = origins.shape[0]
    lam = damping * damping
    _chain_pose_into(q, origins, coords, kinds, axes, joint_axes, joint_origins, T, m)
    for _ in range(iterations):
        for i in range(3):
            e[i] = aim_p[i] - T[i, 3]
        for r in range(3):  # aim_R @ T_R^T
            for c in range(3):
                R[r, c] = aim_R[r, 0] * T[c, 0] + aim_R[r, 1] * T[c, 1] + aim_R[r, 2] * T[c, 2]
        _rotvec_into(R, quat, rv)
        e[3], e[4], e[5] = rv[0], rv[1], rv[2]
        s = 0.0  # np.sum(e * e), term by term in the same order
        for i in range(6):
            s += e[i] * e[i]
        if math.sqrt(s) < 1e-6:
            break
        J[:] = 0.0
        for f in range(n):
            c = coords[f]
            if c < 0:
                continue
            a0, a1, a2 = joint_axes[f, 0], joint_axes[f, 1], joint_axes[f, 2]
            if kinds[f] == PRISMATIC:
                J[0, c], J[1, c], J[2, c] = a0, a1, a2
            else:
                d0, d1, d2 = T[0, 3] - joint_origins[f, 0], T[1, 3] - joint_origins[f, 1], T[2, 3] - joint_origins[f, 2]
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
        _chain_pose_into(q, origins, coords, kinds, axes, joint_axes, joint_origins, T, m)


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
