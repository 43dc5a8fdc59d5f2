"""A differentiable collision loss for Pnet's proposals (a recipe option, `collision_loss`).

Where the free space is narrow (the arm under a table), a proposal as far from the expert's
next waypoint as elsewhere lands in an obstacle; mean squared error in joint space does not
know which errors collide. MπNets (Fishman et al., CoRL 2022) train with a collision loss
beside behaviour cloning: here, the robot's sphere model (the sphere checker's spheres, posed
by forward kinematics in torch) against each training scene's primitives, each sphere's
penetration (its radius plus the margin, less the signed distance from its centre to an
obstacle) hinged at zero and summed. Torch, not the compiled kernels: the loss needs gradients.
"""

from __future__ import annotations

import numpy as np
import torch

from mpnet.envs.arm.model import PRISMATIC, REVOLUTE

FAR = 1.0e3  # where padding obstacles sit (metres): no sphere reaches them


def _pad(rows: list[np.ndarray], width: int, filler: np.ndarray) -> torch.Tensor:
    """(W, n_max, width): each workspace's rows, padded with `filler` (an obstacle far away)."""
    n = max(1, max(len(r) for r in rows))
    out = np.tile(filler, (len(rows), n, 1)).astype(np.float32)
    for i, r in enumerate(rows):
        if len(r):
            out[i, : len(r)] = r.reshape(-1, width)
    return torch.from_numpy(out)


class Clearance:
    """Poses a robot's spheres at joint vectors and measures how deep they sit in each
    workspace's obstacles. `arrays`: Robot.clearance_arrays (a body and one obstacle dict a
    workspace, in the training data's workspace order); `margin`: the clearance the checker
    asks for (the env's planning margin). Plain tensors, not an nn.Module: nothing of it is
    saved with the networks."""

    def __init__(self, arrays: dict, margin: float = 0.0):
        body = arrays["body"]
        self.parent = [int(p) for p in body["parent"]]
        self.kind = [int(k) for k in body["kind"]]
        self.coord = [int(c) for c in body["coord"]]
        self.origin = torch.as_tensor(np.asarray(body["origin"], np.float32))  # (F, 3, 4)
        self.axis = torch.as_tensor(np.asarray(body["axis"], np.float32))  # (F, 3)
        self.frame = torch.as_tensor(np.asarray(body["frame"], np.int64))  # (S,)
        self.local = torch.as_tensor(np.asarray(body["local"], np.float32))  # (S, 3)
        self.radius = torch.as_tensor(np.asarray(body["radius"], np.float32)) + float(margin)  # (S,)
        # The groups' bounding spheres: a group whose bounding sphere misses an obstacle has no
        # sphere in it, so only the spheres of groups that touch one are measured (exactly
        # the sum over all spheres, at a fraction of the cost).
        self.group_frame = torch.as_tensor(np.asarray(body["group_frame"], np.int64))
        self.group_local = torch.as_tensor(np.asarray(body["group_local"], np.float32))
        self.group_radius = torch.as_tensor(np.asarray(body["group_radius"], np.float32)) + float(margin)
        start, stop = np.asarray(body["group_start"], np.int64), np.asarray(body["group_stop"], np.int64)
        width = int((stop - start).max())
        members = start[:, None] + np.arange(width)[None]
        self.member_ok = torch.as_tensor(members < stop[:, None])  # (G, M)
        self.members = torch.as_tensor(np.where(members < stop[:, None], members, 0))  # (G, M)
        obstacles = arrays["obstacles"]
        if not obstacles:
            raise ValueError("no workspaces")
        far_box = np.array([FAR] * 3 + [1, 0, 0, 0, 1, 0, 0, 0, 1] + [0] * 3, np.float32)
        self.boxes = _pad([o["boxes"] for o in obstacles], 15, far_box)  # (W, B, 15)
        self.cylinders = _pad([o["cylinders"] for o in obstacles], 8, np.array([FAR] * 3 + [0, 0, 1, 0, 0], np.float32))
        self.balls = _pad([o["balls"] for o in obstacles], 4, np.array([FAR] * 3 + [0], np.float32))
        # each obstacle's reach from its centre (box: half its diagonal; cylinder: from its centre to
        # its rim; ball: its radius), padding's 0: a screen that skips the exact distance where
        # a group's bounding sphere cannot touch (padding included)
        self.reach = (
            _norm(self.boxes[..., 12:15]),
            torch.sqrt(self.cylinders[..., 6] ** 2 + self.cylinders[..., 7] ** 2),
            self.balls[..., 3],
        )

    def spheres(self, q: torch.Tensor) -> torch.Tensor:
        """(N, S, 3): every sphere's centre at the joint vectors q (N, dof)."""
        return _posed(*self._frames(q), self.frame, self.local)

    def _frames(self, q: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(N, F, 3, 3), (N, F, 3): every frame's rotation and position at q (N, dof)."""
        n = q.shape[0]
        rot, pos = [], []
        for f, (p, kind, c) in enumerate(zip(self.parent, self.kind, self.coord)):
            r, t = self.origin[f, :, :3].expand(n, 3, 3), self.origin[f, :, 3].expand(n, 3)
            if c >= 0 and kind == REVOLUTE:
                r = r @ _rotation(self.axis[f], q[:, c])
            elif c >= 0 and kind == PRISMATIC:
                t = t + (r @ self.axis[f]) * q[:, c : c + 1]
            if p >= 0:
                t = (rot[p] @ t.unsqueeze(-1)).squeeze(-1) + pos[p]
                r = rot[p] @ r
            rot.append(r)
            pos.append(t)
        return torch.stack(rot, 1), torch.stack(pos, 1)

    def penetration(self, q: torch.Tensor, ws: torch.Tensor) -> torch.Tensor:
        """(N,): the summed depth (metres) of every sphere inside every obstacle of its
        workspace (ws (N,), rows of the arrays' workspaces), radius and margin included. Only
        the spheres of groups that touch an obstacle are posed, each group by its one frame
        (a group's spheres share their link's), gathered with index_select: its gradient is
        a plain index_add, where advanced indexing's accumulating scatter cost most of a step."""
        rot, pos = self._frames(q)
        frames = rot.shape[1]
        flat_rot, flat_pos = rot.reshape(-1, 3, 3), pos.reshape(-1, 3)
        with torch.no_grad():
            groups = _posed(rot, pos, self.group_frame, self.group_local)  # (N, G, 3)
        depth = (q * 0.0).sum(-1)  # zeros, on the graph even where nothing touches
        for obstacles, reach, distance in zip(
            (self.boxes, self.cylinders, self.balls), self.reach, (_box_distance, _cylinder_distance, _ball_distance)
        ):
            mine = obstacles[ws]  # (N, O, k)
            with torch.no_grad():
                n, g, o = _near(groups, self.group_radius, mine, reach[ws], distance)
            if not len(n):
                continue
            at = n * frames + self.group_frame[g]  # each touching group's frame at its state
            r, t = flat_rot.index_select(0, at), flat_pos.index_select(0, at)  # (T, 3, 3), (T, 3)
            members = self.members[g]  # (T, M): the spheres of each touching group
            centres = self.local[members] @ r.transpose(1, 2) + t.unsqueeze(1)  # (T, M, 3)
            d = distance(centres, mine[n, o].unsqueeze(1))  # (T, M)
            pen = torch.relu(self.radius[members] - d) * self.member_ok[g]
            depth = depth.index_add(0, n, pen.sum(1))
        return depth


def _near(groups, radius, obstacles, reach, distance) -> tuple[torch.Tensor, ...]:
    """(state, group, obstacle) of every group (N, G, 3) whose bounding sphere (radius (G,))
    touches an obstacle of its state's scene (N, O, k; reach (N, O)), in row-major order: the
    exact distance only where the spheres around group and obstacle meet (1 mm to spare for
    rounding), not for every triple (most are far apart, and padding)."""
    apart = torch.cdist(groups, obstacles[..., :3], compute_mode="donot_use_mm_for_euclid_dist")  # (N, G, O)
    n, g, o = (apart < radius[None, :, None] + reach[:, None, :] + 1e-3).nonzero(as_tuple=True)
    near = distance(groups[n, g], obstacles[n, o]) < radius[g]
    return n[near], g[near], o[near]


def _posed(rot: torch.Tensor, pos: torch.Tensor, frame: torch.Tensor, local: torch.Tensor) -> torch.Tensor:
    """(N, K, 3): points given in their frames (frame (K,), local (K, 3)), posed by the frames' poses."""
    return (rot[:, frame] @ local.unsqueeze(-1)).squeeze(-1) + pos[:, frame]


def _rotation(axis: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    """(N, 3, 3): rotations by `angle` (N,) about the unit `axis` (3,) (Rodrigues): torch's twin of
    mpnet.envs.arm.kinematics.joint_rotation, batched and differentiable (the loss needs its gradient)."""
    x, y, z = axis
    c, s = torch.cos(angle), torch.sin(angle)
    k = 1 - c
    return torch.stack(
        [
            torch.stack([c + x * x * k, x * y * k - z * s, x * z * k + y * s], -1),
            torch.stack([y * x * k + z * s, c + y * y * k, y * z * k - x * s], -1),
            torch.stack([z * x * k - y * s, z * y * k + x * s, c + z * z * k], -1),
        ],
        -2,
    )


def _norm(v: torch.Tensor) -> torch.Tensor:
    """A norm whose gradient is finite at zero."""
    return torch.sqrt((v * v).sum(-1) + 1e-12)


def _box_distance(p: torch.Tensor, box: torch.Tensor) -> torch.Tensor:
    """Signed distance from points p (..., 3) to oriented boxes (..., 15)."""
    rot = box[..., 3:12].unflatten(-1, (3, 3))  # rows: the box's axes (the packed columns)
    local = (rot @ (p - box[..., :3]).unsqueeze(-1)).squeeze(-1).abs() - box[..., 12:15]
    return _norm(torch.relu(local)) + torch.clamp(local.max(-1).values, max=0.0)


def _cylinder_distance(p: torch.Tensor, cyl: torch.Tensor) -> torch.Tensor:
    """Signed distance from points p (..., 3) to capped cylinders (..., 8)."""
    d = p - cyl[..., :3]
    axis = cyl[..., 3:6]
    h = (d * axis).sum(-1)
    radial = _norm(d - h.unsqueeze(-1) * axis) - cyl[..., 6]
    along = h.abs() - cyl[..., 7]
    out = torch.stack([radial, along], -1)
    return _norm(torch.relu(out)) + torch.clamp(out.max(-1).values, max=0.0)


def _ball_distance(p: torch.Tensor, ball: torch.Tensor) -> torch.Tensor:
    return _norm(p - ball[..., :3]) - ball[..., 3]


__all__ = ["Clearance"]
