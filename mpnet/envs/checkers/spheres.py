"""The sphere checker (`env.collision=spheres`, the arm's default): the arm model's sphere
set (a covering of its collision meshes, mpnet.envs.arm.spherize) tested in compiled code
(mpnet.envs.checkers.sphere_kernels) against the workspace's posed boxes, cylinders and spheres and
against the links it may not touch.

Because the spheres cover pybullet's meshes, a configuration this checker calls free is
free for pybullet too (tests/mpnet/envs/checkers/test_spheres.py measures it); because motions are certified
(a bound on how far each sphere moves per radian of each joint), a motion it calls free
has no sphere touching anything anywhere along it, at any resolution.
"""

from __future__ import annotations

import copy
import json
from functools import cache

import numpy as np

from mpnet.envs.arm.kinematics import forward
from mpnet.envs.arm.model import PRISMATIC, ArmModel, ArmModelError, load_arm_model
from mpnet.envs.checkers import sphere_checks as C
from mpnet.envs.checkers import sphere_kernels as K
from mpnet.envs.checkers import sphere_layout
from mpnet.envs.checkers.collision import SampledConfigurations
from mpnet.envs.checkers.hull_kernels import BULLET_MARGIN
from mpnet.envs.checkers.sphere_bounds import LEVER, SWEPT
from mpnet.envs.checkers.sphere_store import stored
from mpnet.envs.workspace import Workspace

# A motion whose spheres would still touch something with less growth than this (metres)
# is called blocked: certification stops there rather than halving forever.
CERTIFY_TOL = 1e-4


def read_spheres(model: ArmModel) -> dict:
    """The model's sphere set (mpnet.envs.arm.spherize's JSON), from its robot folder."""
    path = model.spheres_path
    if path is None:
        raise ArmModelError(
            f"arm model {model.name}: no sphere set {model.spheres} yet (python -m harness.spherize {model.name})"
        )
    return json.loads(path.read_text(encoding="utf-8"))


class SphereModel:
    """A model's spheres and kinematics as the kernels' arrays (see sphere_kernels)."""

    def __init__(self, model: ArmModel, doc: dict | None = None):
        """doc: the model's sphere set as read (None: read here, read_spheres)."""
        kin = model.kinematics
        self.bound = LEVER  # the motion bound (sphere_bounds): sphere_model gives SWEPT's
        doc = read_spheres(model) if doc is None else doc
        self.model = model
        frames = kin.frames
        self.parent, self.origin, self.kind, self.axis, self.coord = kin.arrays()
        # Links no joint moves (the root's and those fixed to it: a pedestal, a mobile base) go
        # first, each kind in frame order (an ancestor still before its descendants): the kernels
        # skip them against obstacles, which _base_blocked tests once a workspace.
        links = [f.link for f in frames if f.link in doc["links"]]
        fixed = {name for name in links if _root_fixed(frames, kin.index(name))}
        links = [name for name in links if name in fixed] + [name for name in links if name not in fixed]
        self.links = links
        self.link_frame = np.array([kin.index(name) for name in links], np.int64)
        spheres = [_grouped(np.array(doc["links"][name], float).reshape(-1, 4)) for name in links]
        groups = [g for link in spheres for g in link]
        gsizes = np.array([len(g) for g in groups])
        per_link = np.array([len(link) for link in spheres])
        self.link_g1 = np.cumsum(per_link).astype(np.int64)
        self.link_g0 = self.link_g1 - per_link
        self.group_s1 = np.cumsum(gsizes).astype(np.int64)
        self.group_s0 = self.group_s1 - gsizes
        self.group_frame = np.repeat(self.link_frame, per_link)
        allsph = np.concatenate(groups)
        self.local = np.ascontiguousarray(allsph[:, :3])
        self.radius = np.ascontiguousarray(allsph[:, 3])
        self.blocal, self.bradius = _bounds([np.concatenate(link) for link in spheres])
        self.glocal, self.gradius = _bounds(groups)
        pairs = [
            (a, b)
            for a in range(len(links))
            for b in range(a + 1, len(links))
            if not model.is_allowed(links[a], links[b]) and not self._parent_child(links[a], links[b])
        ]
        self.pair_a = np.array([p[0] for p in pairs], np.int64)
        self.pair_b = np.array([p[1] for p in pairs], np.int64)
        self.pair_j0 = np.array([self._joints_between(a, b) for a, b in pairs], np.int64)
        self.pair_exact, self.link_h0, self.link_h1, self.link_hr, self.hull = self._hulls(pairs)
        # How many links never move (the first ones): tested against a workspace's obstacles once.
        self.first = len(fixed)
        self.sphere_frame = np.repeat(self.group_frame, gsizes)
        self.sphere_link = np.repeat(np.repeat(np.arange(len(links)), per_link), gsizes)
        # Static levers per sphere (the kernels use the links' and groups', which bound them).
        self.lever = self._levers(self.sphere_frame, self.local, model.dof)
        self.llever = self._levers(self.link_frame, self.blocal, model.dof)
        self.glever = self._levers(self.group_frame, self.glocal, model.dof)
        self._check_chain()
        nj = self._joints_moving()
        self.lnj, self.gnj = nj[self.link_frame], nj[self.group_frame]
        self.lower = np.array([b[0] for b in model.limits])
        self.upper = np.array([b[1] for b in model.limits])
        self.pair_table = np.full(len(pairs), -1, np.int64)
        # The pair tables (_build_tables): rows of ints, rows of floats, their bits (which
        # cells are free) and the kernels' summed-area counts of the cells that are not
        self.table_i, self.table_f = np.zeros((0, 5), np.int64), np.zeros((0, 4))
        self.table_bits, self.table_sum = np.zeros(0, np.int64), np.zeros(0, np.int64)
        self._pack()
        self._build_tables()
        self.link_sizes = np.array([sum(len(g) for g in link) for link in spheres])

    def _hulls(self, pairs: list[tuple[int, int]]):
        """The pairs tested on their convex hulls (the model's exact_pairs: 1, else 0) and the
        convex cores' vertices (link frames: a hull's, a sphere's centre), each link's from
        link_h0 to link_h1, and how far the judge's shape reaches beyond each (a sphere's radius,
        a hull's pybullet margin)."""
        links, model = self.links, self.model
        named = [(min(links[a], links[b]), max(links[a], links[b])) for a, b in pairs]
        untested = sorted(model.exact_pairs - set(named))
        if untested:
            a, b = untested[0]
            raise ArmModelError(f"{model.name}: exact pair ({a}, {b}) is never tested (allowed, or parent and child)")
        exact = np.array([key in model.exact_pairs for key in named])
        h0, h1, verts = np.zeros(len(links), np.int64), np.zeros(len(links), np.int64), [np.zeros((0, 3))]
        hr = np.zeros(len(links))
        hulled = {name for pair in model.exact_pairs for name in pair}
        if hulled:
            # here, not at the top: only a model with exact pairs pays scipy.spatial's import
            from mpnet.envs.arm.spherize import link_core

            for i, name in enumerate(links):
                if name in hulled:
                    core, radius = link_core(model, name)
                    hr[i] = radius + (BULLET_MARGIN if len(core) > 1 else 0.0)  # a hull's margin; a sphere is itself
                    h0[i] = sum(len(v) for v in verts)
                    verts.append(core)
                    h1[i] = h0[i] + len(core)
        return exact.astype(np.int64), h0, h1, hr, np.ascontiguousarray(np.concatenate(verts))

    def _pack(self) -> None:
        """The kernels' packed arrays and the scratch's length (sphere_layout lays them out)."""
        self.mi, self.mf, self._buffer_size = sphere_layout.pack(self)

    def _build_tables(self) -> None:
        """Pair tables (sphere_kernels.build_table) for the self-collision pairs whose
        relative pose depends on at most two revolute joints (the Panda's wrist: link5
        against link7, the hand and the fingers, which are near each other in every
        configuration and would otherwise be tested sphere by sphere every time)."""
        partners: dict[tuple[int, tuple[int, ...]], list[int]] = {}
        for pi, (a, b) in enumerate(zip(self.pair_a.tolist(), self.pair_b.tolist())):
            coords = self._coords_between(a, b)
            if coords is not None and 1 <= len(coords) <= 2:
                partners.setdefault((a, coords), []).append(pi)
        rows_i, rows_f, words, sums = [], [], [], []
        for t, ((a, coords), pis) in enumerate(partners.items()):
            lo = np.array([self.lower[c] for c in coords] + [0.0] * (2 - len(coords)))
            hi = np.array([self.upper[c] for c in coords] + [1.0] * (2 - len(coords)))
            n = np.array([TABLE_CELLS] + [TABLE_CELLS if len(coords) == 2 else 1], np.int64)
            width = (hi - lo) / n
            jb = coords[1] if len(coords) == 2 else -1
            bits = K.build_table(
                self.mi, self.mf, self.buffers(), self.lever, a, self.pair_b[pis], coords[0], jb, lo, width, n
            )
            rows_i.append([coords[0], jb, n[0], n[1], sum(len(c) for c in sums)])
            rows_f.append([lo[0], width[0], lo[1], width[1]])
            words.append(bits)
            sums.append(_summed_area(bits, n))
            self.pair_table[pis] = t
        if rows_i:
            self.table_i, self.table_f = np.array(rows_i, np.int64), np.array(rows_f)
            self.table_bits, self.table_sum = np.concatenate(words), np.concatenate(sums)
            self._pack()

    def _coords_between(self, a: int, b: int) -> tuple[int, ...] | None:
        """The revolute joints that move link b relative to link a, a an ancestor of b
        (None when it is not, or a prismatic joint lies between)."""
        frames = self.model.kinematics.frames
        fa, i = int(self.link_frame[a]), int(self.link_frame[b])
        coords = []
        while i >= 0 and i != fa:
            if frames[i].coordinate >= 0:
                if frames[i].kind == PRISMATIC:
                    return None
                coords.append(frames[i].coordinate)
            i = frames[i].parent
        return tuple(sorted(coords)) if i >= 0 else None

    def _check_chain(self) -> None:
        """The motion bound orders joints along the chain: coordinate k + 1's joint must
        lie below coordinate k's."""
        frames = self.model.kinematics.frames
        at = {f.coordinate: i for i, f in enumerate(frames) if f.coordinate >= 0}
        for k in range(1, len(at)):
            i = at[k]
            while i >= 0 and i != at[k - 1]:
                i = frames[i].parent
            if i < 0:
                raise ValueError(
                    f"{self.model.name}: joint {self.model.joints[k]} is not below {self.model.joints[k - 1]}"
                )

    def _joints_moving(self) -> np.ndarray:
        """Per frame, how many joints move it: its ancestors' coordinates, 0 .. n - 1 (the
        coordinates run along the chain: _check_chain)."""
        frames = self.model.kinematics.frames
        out = np.zeros(len(frames), np.int64)
        for i, f in enumerate(frames):  # parents before children
            out[i] = max(out[f.parent] if f.parent >= 0 else 0, f.coordinate + 1)
        return out

    def _joints_between(self, a: int, b: int) -> int:
        """The first coordinate whose joint lies between links a and b when a is an ancestor
        of b (the joints that move b relative to a are it and the ones after it); -1 when
        neither is the other's ancestor."""
        frames = self.model.kinematics.frames
        fa, i = int(self.link_frame[a]), int(self.link_frame[b])
        first = -1
        while i >= 0 and i != fa:
            if frames[i].coordinate >= 0:
                first = frames[i].coordinate
            i = frames[i].parent
        if i < 0:
            return -1
        return first if first >= 0 else self.model.dof

    def _parent_child(self, a: str, b: str) -> bool:
        """Links joined by one joint (pybullet never checks them either)."""
        frames = self.model.kinematics.frames
        ia, ib = (self.model.kinematics.index(x) for x in (a, b))
        return frames[ia].parent == ib or frames[ib].parent == ia

    def _levers(self, frame_of: np.ndarray, local: np.ndarray, dof: int) -> np.ndarray:
        """(n, dof): a bound on how far each point (local coordinates in frame frame_of[i])
        moves per unit of each joint: for a revolute joint, its distance from the joint's
        axis, bounded by the lengths of the fixed offsets from the joint to the point (the
        triangle inequality, in any configuration, a prismatic joint on the way counted at its
        farthest limit); for a prismatic joint, 1."""
        frames, limits = self.model.kinematics.frames, self.model.limits
        out = np.zeros((len(frame_of), dof))
        for i, f in enumerate(frame_of):
            reach = float(np.linalg.norm(local[i]))
            k = int(f)
            while k >= 0:
                fr = frames[k]
                if fr.coordinate >= 0:
                    out[i, fr.coordinate] = 1.0 if fr.kind == PRISMATIC else reach
                    if fr.kind == PRISMATIC:  # it slides what is below it along its axis
                        reach += max(abs(v) for v in limits[fr.coordinate])
                reach += float(np.linalg.norm(fr.origin[:3, 3]))
                k = fr.parent
        return out

    def buffers(self) -> np.ndarray:
        """Scratch the kernels write into (one per checker)."""
        return np.zeros(self._buffer_size)

    def world_spheres(self, q) -> np.ndarray:
        """(S, 4): every sphere's centre in the base frame and its radius at q."""
        pose = np.zeros((len(self.parent) + 1, 3, 4))
        forward(np.asarray(q, float), self.parent, self.origin, self.kind, self.axis, self.coord, pose)
        frame = self.sphere_frame
        centres = np.einsum("nij,nj->ni", pose[frame, :, :3], self.local) + pose[frame, :, 3]
        return np.column_stack([centres, self.radius])

    def moving_body(self) -> dict[str, np.ndarray]:
        """The kinematic chain and the spheres of every link that moves (the root link's,
        which no joint moves, left out): what a differentiable collision loss
        (mpnet.models.clearance) poses in torch. Frames: parent index (-1: the base), origin
        (F, 3, 4), joint kind, axis and coordinate (-1: fixed); spheres: frame, centre in it, radius;
        their groups (the checker's tree): frame, bounding sphere, and first and last + 1 sphere."""
        g0 = int(self.link_g1[self.first - 1]) if self.first else 0  # the first group, and its first sphere, that move
        s0 = int(self.group_s0[g0]) if g0 < len(self.group_s0) else len(self.radius)
        return {
            "parent": self.parent,
            "origin": self.origin,
            "kind": self.kind,
            "axis": self.axis,
            "coord": self.coord,
            "frame": self.sphere_frame[s0:],
            "local": self.local[s0:],
            "radius": self.radius[s0:],
            "group_frame": self.group_frame[g0:],
            "group_local": self.glocal[g0:],
            "group_radius": self.gradius[g0:],
            "group_start": self.group_s0[g0:] - s0,
            "group_stop": self.group_s1[g0:] - s0,
        }


def _root_fixed(frames, i: int) -> bool:
    """No joint lies between frame i and the root (its pose is the same in every configuration)."""
    while i >= 0:
        if frames[i].coordinate >= 0:
            return False
        i = frames[i].parent
    return True


def obstacle_arrays(ws: Workspace) -> dict[str, np.ndarray]:
    """The workspace's primitives as arrays (the packed layout's, sphere_kernels.unpack_obstacles):
    boxes (B, 15: centre, rotation's columns, half sizes), cylinders (C, 8: centre, axis,
    radius, half height), balls (K, 4: centre, radius)."""
    boxes, cyls, balls, _, _ = K.obstacle_views(pack_obstacles(ws, 0.0))
    return {"boxes": boxes.copy(), "cylinders": cyls.copy(), "balls": balls.copy()}


TABLE_CELLS = 256  # a pair table's cells along each of its joints


def _summed_area(bits: np.ndarray, n) -> np.ndarray:
    """A pair table's summed-area counts ((n[0] + 1) x (n[1] + 1), flat) of the cells its bits
    do not call free: entry [i, k] counts those below i along its first joint and below k
    along its second (sphere_kernels._table_free reads any box of cells in four entries)."""
    free = np.unpackbits(bits.view(np.uint8), bitorder="little")[: n[0] * n[1]].reshape(n[0], n[1])
    out = np.zeros((n[0] + 1, n[1] + 1), np.int64)
    out[1:, 1:] = (1 - free.astype(np.int64)).cumsum(0).cumsum(1)
    return out.ravel()


GROUP = 8  # spheres per group of the tree (about): a link's groups are tested before its spheres


def _grouped(spheres: np.ndarray) -> list[np.ndarray]:
    """A link's spheres split into groups of about GROUP neighbours (k-means on the centres,
    seeded: the same model always gives the same tree)."""
    k = max(1, round(len(spheres) / GROUP))
    if k == 1:
        return [spheres]
    from scipy.cluster.vq import kmeans2  # here, not at the top: scipy.cluster costs every run ~0.3 s to import

    _, label = kmeans2(spheres[:, :3], k, minit="++", seed=np.random.default_rng(0), iter=30)
    return [spheres[label == j] for j in range(k) if (label == j).any()]


def _bounds(sets: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """A bounding sphere (centre, radius) of each set of spheres."""
    centres = np.array([(s[:, :3].min(axis=0) + s[:, :3].max(axis=0)) / 2 for s in sets])
    radii = np.array([float((np.linalg.norm(s[:, :3] - c, axis=1) + s[:, 3]).max()) for s, c in zip(sets, centres)])
    return centres, radii


@cache
def sphere_model(name: str, bound: int = LEVER) -> SphereModel:
    """The model of arm `name` with motion bound `bound`: another bound is the same model (its
    spheres, levers and pair tables shared, not built again) packed with that bound."""
    if bound == LEVER:
        return stored(load_arm_model(name), SphereModel)
    other = copy.copy(sphere_model(name))
    other.bound = bound
    other._pack()
    return other


def pack_obstacles(ws: Workspace, margin: float) -> np.ndarray:
    """The workspace's primitives as the kernels' packed obstacle array (see
    sphere_kernels.unpack_obstacles), each with its axis-aligned bounds."""
    boxes, cyls, balls = [], [], []
    bounds = {"box": [], "cylinder": [], "sphere": []}
    for p in ws.all_primitives():
        r = p.rotation()
        c = np.asarray(p.center, float)
        if p.type == "box":
            half = np.asarray(p.size, float) / 2
            boxes.append([*c, *r[:, 0], *r[:, 1], *r[:, 2], *half])
            extent = np.abs(r) @ half
        elif p.type == "cylinder":
            a = r[:, 2]
            cyls.append([*c, *a, p.radius, p.height / 2])
            extent = p.radius * np.sqrt(np.clip(1.0 - a * a, 0.0, None)) + abs(a) * p.height / 2
        else:
            balls.append([*c, p.radius])
            extent = np.full(3, float(p.radius))
        extent = extent + 1e-9  # rounding: the bounds must contain the obstacle
        bounds[p.type].append([*(c - extent), *(c + extent)])
    rows = bounds["box"] + bounds["cylinder"] + bounds["sphere"]
    return np.concatenate(
        [[len(boxes), len(cyls), len(balls), float(margin)], np.ravel(boxes), np.ravel(cyls), np.ravel(balls)]
        + [np.ravel(rows)]
    ).astype(float)


class SphereChecker(SampledConfigurations):
    """The compiled sphere checker (see the module docstring); `configurations_checked`
    counts sphere-model evaluations, motions' included."""

    # Bumped whenever a change can change an answer (the motion bound, the tests): it is in
    # every arm cache key, so data built by another version is rebuilt, never reused.
    # 2: pair tables (a motion NEAR by the growth bound can be free by a table); 3: a table
    # answers a motion interval over any number of its cells (2: at most 16, else the spheres)
    VERSION = 3
    BOUND = LEVER  # how far a sphere moves in a motion interval (sphere_bounds)
    compiled = True

    def compiled_env(self) -> tuple:
        """The sphere model's arrays as the compiled planners' env (mpnet.envs.checkers.spheres_compiled)."""
        from mpnet.envs.checkers import spheres_compiled  # numba's kernels load with the compiled planner only

        mi, mf, ob, lo_, up_ = self._args
        return spheres_compiled.env(mi, mf, ob, CERTIFY_TOL, self.base_blocked, lo_, up_, self._buf)

    def __init__(self, spec, ws: Workspace, margin: float):
        super().__init__(spec, ws, margin)
        self.model = m = sphere_model(spec.robot.model.name, self.BOUND)
        self._args = (m.mi, m.mf, pack_obstacles(ws, margin), m.lower, m.upper)
        self._buf = m.buffers()
        self.base_blocked = self._base_blocked()

    def _base_blocked(self) -> bool:
        m = self.model
        if not m.first:
            return False
        base = m.world_spheres(np.zeros(m.model.dof))[: m.link_sizes[: m.first].sum()]
        return bool(C.any_hit(np.ascontiguousarray(base[:, :3]), np.ascontiguousarray(base[:, 3]), self._args[2]))

    def _state_free(self, q) -> bool:
        self.configurations += 1
        return not self.base_blocked and C.state_free(np.asarray(q, float), *self._args, self._buf)

    def _motion_free(self, a, b) -> bool:
        if self.base_blocked:
            return False
        ok, n = C.motion_free(np.asarray(a, float), np.asarray(b, float), *self._args, CERTIFY_TOL, self._buf)
        self.configurations += n
        return bool(ok)

    def _states_free(self, qs: np.ndarray) -> np.ndarray:
        self.configurations += len(qs)
        if self.base_blocked:
            return np.zeros(len(qs), bool)
        return C.states_free(np.ascontiguousarray(qs), *self._args, self._buf)

    def _motions_free(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        if self.base_blocked:
            return np.zeros(len(a), bool)
        out, n = C.motions_free(np.ascontiguousarray(a), np.ascontiguousarray(b), *self._args, CERTIFY_TOL, self._buf)
        self.configurations += int(n)
        return out


class SweptSphereChecker(SphereChecker):
    """`env.collision=spheres_swept`: the sphere checker with SWEPT's motion bound (a sphere's
    velocity summed as a vector over the joints that move it: sphere_bounds), which certifies
    an arm's motion in about a third fewer configurations. Its answers differ from `spheres`'
    only where a motion passes within the certification's tolerance (0.1 mm) of a contact;
    data is built with the env's default checker (`spheres`), so this is a planning choice."""

    VERSION = 1  # its own versions (the backend's name is in a cache key, should data ever be built with it)
    BOUND = SWEPT
