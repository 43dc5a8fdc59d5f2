"""An arm's forward kinematics and its joints' rotation, written once (numba): the sphere
checker's poses (mpnet.envs.checkers.sphere_kernels), inverse kinematics' (ik_kernels, on a
chain of its own: ik.chain_arrays) and the model's numpy ones (model.Kinematics.link_transforms)
all come from `forward`, every revolute joint's rotation from `joint_rotation`.

Frames are arrays in parent-before-child order: parent index (-1: the base), the fixed origin
transform of the frame's joint (3 x 4: its last row is 0 0 0 1), the joint's kind (FIXED,
REVOLUTE, PRISMATIC: arm.model's, asserted equal in arm.ik) and unit axis, and the planned
coordinate that drives it (-1: none). A frame's pose is its parent's times (origin times its
joint's motion), multiplied in that order; torch's differentiable twin is
mpnet.models.clearance's (the collision loss needs gradients).
"""

from __future__ import annotations

import math

from mpnet.jit import njit

FIXED, REVOLUTE, PRISMATIC = 0, 1, 2


@njit(cache=True, borrowed=True)
def joint_rotation(x, y, z, v):
    """The rotation by angle v about the unit axis (x, y, z) (Rodrigues), its rows as nine
    numbers r00, r01, r02, r10, ..., r22."""
    cs, sn = math.cos(v), math.sin(v)
    C = 1.0 - cs
    return (
        cs + x * x * C,
        x * y * C - z * sn,
        x * z * C + y * sn,
        y * x * C + z * sn,
        cs + y * y * C,
        y * z * C - x * sn,
        z * x * C - y * sn,
        z * y * C + x * sn,
        cs + z * z * C,
    )


@njit(cache=True, borrowed=True)
def forward(q, parent, origin, kind, axis, coord, out):
    """Every frame's pose (3 x 4, base frame) at joint vector q, into out[:F]; out[F] is
    scratch. Scalar loops throughout: array slicing costs more than the arithmetic here."""
    F = parent.shape[0]
    m = out[F]
    for f in range(F):
        for i in range(3):
            for j in range(4):
                m[i, j] = origin[f, i, j]
        c = coord[f]
        if c >= 0:
            v = q[c]
            if kind[f] == REVOLUTE:
                x, y, z = axis[f, 0], axis[f, 1], axis[f, 2]
                r00, r01, r02, r10, r11, r12, r20, r21, r22 = joint_rotation(x, y, z, v)
                if x == 0.0 and y == 0.0 and z == 1.0:
                    # the product below less its zero terms (r02, r12, r20, r21): the same numbers
                    for i in range(3):
                        a0, a1 = origin[f, i, 0], origin[f, i, 1]
                        m[i, 0] = a0 * r00 + a1 * r10
                        m[i, 1] = a0 * r01 + a1 * r11
                        m[i, 2] = origin[f, i, 2] * r22
                else:
                    for i in range(3):
                        a0, a1, a2 = origin[f, i, 0], origin[f, i, 1], origin[f, i, 2]
                        m[i, 0] = a0 * r00 + a1 * r10 + a2 * r20
                        m[i, 1] = a0 * r01 + a1 * r11 + a2 * r21
                        m[i, 2] = a0 * r02 + a1 * r12 + a2 * r22
            else:
                for i in range(3):
                    m[i, 3] += v * (
                        origin[f, i, 0] * axis[f, 0] + origin[f, i, 1] * axis[f, 1] + origin[f, i, 2] * axis[f, 2]
                    )
        p = parent[f]
        if p < 0:
            for i in range(3):
                for j in range(4):
                    out[f, i, j] = m[i, j]
        else:
            for i in range(3):
                p0, p1, p2 = out[p, i, 0], out[p, i, 1], out[p, i, 2]
                for j in range(3):
                    out[f, i, j] = p0 * m[0, j] + p1 * m[1, j] + p2 * m[2, j]
                out[f, i, 3] = p0 * m[0, 3] + p1 * m[1, 3] + p2 * m[2, 3] + out[p, i, 3]
