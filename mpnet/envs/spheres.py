"""The sphere checker (`env.collision=spheres`, the arm's default): the arm model's sphere
set (a covering of its collision meshes, mpnet.envs.spherize) tested in compiled code
(mpnet.envs.sphere_kernels) against the workspace's posed boxes, cylinders and spheres and
against the links it may not touch.

Because the spheres cover pybullet's meshes, a configuration this checker calls free is
free for pybullet too (tests/test_spheres.py measures it); because motions are certified
(a bound on how far each sphere moves per radian of each joint), a motion it calls free
has no sphere touching anything anywhere along it, at any resolution.
"""

from __future__ import annotations

import json
from functools import cache
from importlib import resources

import numpy as np
from mpnet.envs import sphere_kernels as K
from mpnet.envs.arm_model import PRISMATIC, ArmModel, load_arm_model
from mpnet.envs.collision import CollisionChecker
from mpnet.envs.workspace import Workspace

# A motion whose spheres would still touch something with less growth than this (metres)
# is called blocked: certification stops there rather than halving forever.
CERTIFY_TOL = 1e-4


def read_spheres(model: ArmModel) -> dict:
    return json.loads((resources.files("mpnet") / "data_files" / "robots" / model.spheres).read_text(encoding="utf-8"))


class SphereModel:
    """A model's spheres and kinematics as the kernels' arrays (see sphere_kernels)."""

    def __init__(self, model: ArmModel):
        kin = model.kinematics
        doc = read_spheres(model)
        self.model = model
        frames = kin.frames
        self.parent = np.array([f.parent for f in frames], np.int64)
        self.origin = np.ascontiguousarray(np.array([f.origin[:3] for f in frames]))
        self.kind = np.array([f.kind for f in frames], np.int64)
        self.axis = np.array([f.axis for f in frames], float)
        self.coord = np.array([f.coordinate for f in frames], np.int64)
        links = [f.link for f in frames if f.link in doc["links"]]
        self.links = links
        self.link_frame = np.array([kin.index(name) for name in links], np.int64)
        spheres = [np.array(doc["links"][name], float).reshape(-1, 4) for name in links]
        sizes = np.array([len(s) for s in spheres])
        self.link_start = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        self.link_end = np.cumsum(sizes).astype(np.int64)
        allsph = np.concatenate(spheres)
        self.local = np.ascontiguousarray(allsph[:, :3])
        self.radius = np.ascontiguousarray(allsph[:, 3])
        self.blocal = np.empty((len(links), 3))
        self.bradius = np.empty(len(links))
        for li, s in enumerate(spheres):
            c = (s[:, :3].min(axis=0) + s[:, :3].max(axis=0)) / 2
            self.blocal[li] = c
            self.bradius[li] = float((np.linalg.norm(s[:, :3] - c, axis=1) + s[:, 3]).max())
        pairs = [
            (a, b)
            for a in range(len(links))
            for b in range(a + 1, len(links))
            if not model.is_allowed(links[a], links[b]) and not self._parent_child(links[a], links[b])
        ]
        self.pair_a = np.array([p[0] for p in pairs], np.int64)
        self.pair_b = np.array([p[1] for p in pairs], np.int64)
        # The root link never moves: it is tested against a workspace's obstacles once.
        self.first = 1 if self.link_frame[0] == 0 else 0
        sphere_frame = np.repeat(self.link_frame, sizes)
        self.lever = self._levers(sphere_frame, self.local, model.dof)
        self.llever = self._levers(self.link_frame, self.blocal, model.dof)
        self.lower = np.array([b[0] for b in model.limits])
        self.upper = np.array([b[1] for b in model.limits])
        F, L, S, P, D = len(self.parent), len(links), len(self.radius), len(pairs), model.dof
        self.mi = np.concatenate(
            [
                [F, L, S, P, D, self.first],
                self.parent,
                self.kind,
                self.coord,
                self.link_frame,
                self.link_start,
                self.link_end,
                self.pair_a,
                self.pair_b,
            ]
        ).astype(np.int64)
        self.mf = np.concatenate(
            [
                a.ravel()
                for a in (
                    self.origin,
                    self.axis,
                    self.local,
                    self.radius,
                    self.blocal,
                    self.bradius,
                    self.lever,
                    self.llever,
                )
            ]
        )
        self._buffer_size = K.buffer_size(F, L, S, D)

    def _parent_child(self, a: str, b: str) -> bool:
        """Links joined by one joint (pybullet never checks them either)."""
        frames = self.model.kinematics.frames
        ia, ib = (self.model.kinematics.index(x) for x in (a, b))
        return frames[ia].parent == ib or frames[ib].parent == ia

    def _levers(self, frame_of: np.ndarray, local: np.ndarray, dof: int) -> np.ndarray:
        """(n, dof): a bound on how far each point (local coordinates in frame frame_of[i])
        moves per unit of each joint: for a revolute joint, its distance from the joint's
        axis, bounded by the lengths of the fixed offsets from the joint to the point (the
        triangle inequality, in any configuration); for a prismatic joint, 1."""
        frames = self.model.kinematics.frames
        out = np.zeros((len(frame_of), dof))
        for i, f in enumerate(frame_of):
            reach = float(np.linalg.norm(local[i]))
            k = int(f)
            while k >= 0:
                fr = frames[k]
                if fr.coordinate >= 0:
                    out[i, fr.coordinate] = 1.0 if fr.kind == PRISMATIC else reach
                reach += float(np.linalg.norm(fr.origin[:3, 3]))
                k = fr.parent
        return out

    def buffers(self) -> np.ndarray:
        """Scratch the kernels write into (one per checker)."""
        return np.zeros(self._buffer_size)

    def world_spheres(self, q) -> np.ndarray:
        """(S, 4): every sphere's centre in the base frame and its radius at q."""
        pose = np.zeros((len(self.parent) + 1, 3, 4))
        K.forward(np.asarray(q, float), self.parent, self.origin, self.kind, self.axis, self.coord, pose)
        frame = np.repeat(self.link_frame, self.link_end - self.link_start)
        centres = np.einsum("nij,nj->ni", pose[frame, :, :3], self.local) + pose[frame, :, 3]
        return np.column_stack([centres, self.radius])


@cache
def sphere_model(name: str) -> SphereModel:
    return SphereModel(load_arm_model(name))


def pack_obstacles(ws: Workspace, margin: float) -> np.ndarray:
    """The workspace's primitives as the kernels' packed obstacle array."""
    boxes, cyls, balls = [], [], []
    for p in ws.all_primitives():
        r = p.rotation()
        if p.type == "box":
            boxes.append([*p.center, *r[:, 0], *r[:, 1], *r[:, 2], *(s / 2 for s in p.size)])
        elif p.type == "cylinder":
            cyls.append([*p.center, *r[:, 2], p.radius, p.height / 2])
        else:
            balls.append([*p.center, p.radius])
    return np.concatenate(
        [[len(boxes), len(cyls), len(balls), float(margin)], np.ravel(boxes), np.ravel(cyls), np.ravel(balls)]
    ).astype(float)


class SphereChecker(CollisionChecker):
    """The compiled sphere checker (see the module docstring); `configurations_checked`
    counts sphere-model evaluations, motions' included."""

    def __init__(self, spec, ws: Workspace, margin: float):
        super().__init__(spec, ws, margin)
        self.model = m = sphere_model(spec.robot.model.name)
        self._args = (m.mi, m.mf, pack_obstacles(ws, margin), m.lower, m.upper)
        self._buf = m.buffers()
        self.base_blocked = self._base_blocked()
        self.configurations = 0

    def _base_blocked(self) -> bool:
        m = self.model
        if not m.first:
            return False
        base = m.world_spheres(np.zeros(m.model.dof))[m.link_start[0] : m.link_end[0]]
        return bool(K.any_hit(np.ascontiguousarray(base[:, :3]), np.ascontiguousarray(base[:, 3]), self._args[2]))

    def counts(self) -> dict:
        return {**super().counts(), "configurations_checked": self.configurations}

    def reset_counts(self) -> None:
        super().reset_counts()
        self.configurations = 0

    def _state_free(self, q) -> bool:
        self.configurations += 1
        return not self.base_blocked and K.state_free(np.asarray(q, float), *self._args, self._buf)

    def _motion_free(self, a, b) -> bool:
        if self.base_blocked:
            return False
        ok, n = K.motion_free(np.asarray(a, float), np.asarray(b, float), *self._args, CERTIFY_TOL, self._buf)
        self.configurations += n
        return bool(ok)

    def _states_free(self, qs: np.ndarray) -> np.ndarray:
        self.configurations += len(qs)
        if self.base_blocked:
            return np.zeros(len(qs), bool)
        return K.states_free(np.ascontiguousarray(qs), *self._args, self._buf)

    def _motions_free(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        if self.base_blocked:
            return np.zeros(len(a), bool)
        out, n = K.motions_free(np.ascontiguousarray(a), np.ascontiguousarray(b), *self._args, CERTIFY_TOL, self._buf)
        self.configurations += int(n)
        return out
