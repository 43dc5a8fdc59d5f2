"""A sphere covering of an arm's collision meshes: the sphere model the compiled checker
tests (VAMP and cuRobo check spheres the same way).

pybullet tests every collision mesh as its convex hull, so the covering is of the hull,
volume and surface: each link's hull is filled with points (a grid inside, a fine
triangulated grid on every face, every vertex) and covered greedily by balls centred
inside the hull that reach at most `reach` beyond it (a set cover: few spheres, each
hugging the hull, as a medial-axis sphere tree does). Every sphere is padded by `pad`,
which must exceed the gap between the sample points (a point of the hull is never farther
than `spacing` from a sample) plus Bullet's collision margin; the covering tests check
every hull vertex and dense random points of the hulls.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull

from mpnet.envs.arm.model import ArmModel, ArmModelError, CollisionShape
from mpnet.jit import njit

CANDIDATE_SPACING = 0.005  # m between the interior grid's candidate centres
_STL_RECORD = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


def read_obj_vertices(path) -> np.ndarray:
    """The `v x y z` lines of a Wavefront OBJ file."""
    rows = [line.split()[1:4] for line in open(path, encoding="utf-8") if line.startswith("v ")]
    return np.array(rows, float)


def read_stl_vertices(path) -> np.ndarray:
    """The triangle corners of an STL file, binary (80-byte header, count, 50-byte records)
    or ASCII (`vertex x y z` lines). Hand-written: a dozen lines where a mesh library would
    be a dependency for one call."""
    data = Path(path).read_bytes()
    if len(data) >= 84 and 84 + 50 * int.from_bytes(data[80:84], "little") == len(data):
        records = np.frombuffer(data, _STL_RECORD, offset=84)
        return records["corners"].reshape(-1, 3).astype(float)
    rows = [
        line.split()[1:4] for line in data.decode("ascii", "replace").splitlines() if line.strip().startswith("vertex")
    ]
    if not rows:
        raise ArmModelError(f"{path}: neither a binary nor an ASCII STL file")
    return np.array(rows, float)


def read_mesh_vertices(path) -> np.ndarray:
    """A collision mesh's vertices, by its suffix: Wavefront OBJ or STL."""
    suffix = Path(path).suffix.lower()
    if suffix == ".obj":
        return read_obj_vertices(path)
    if suffix == ".stl":
        return read_stl_vertices(path)
    raise ArmModelError(f"{path}: collision meshes are read from OBJ or STL files")


def shape_points(shape: CollisionShape) -> np.ndarray:
    """Points whose convex hull is the shape's (a mesh's vertices, scaled; a box's corners),
    in the link frame."""
    if shape.geometry == "mesh":
        v = read_mesh_vertices(shape.path) * np.asarray(shape.size, float)
    elif shape.geometry == "box":
        v = np.array(np.meshgrid(*[[-h / 2, h / 2] for h in shape.size], indexing="ij")).reshape(3, -1).T
    else:
        raise ArmModelError(f"link {shape.link!r}: a {shape.geometry} has no hull to cover")
    return v @ shape.origin[:3, :3].T + shape.origin[:3, 3]


def link_core(model: ArmModel, link: str) -> tuple[np.ndarray, float]:
    """A link's collision shape as the points of a convex core and a radius around it (the
    shape is the core's hull grown by the radius), in the link frame: a mesh's or a box's hull
    vertices and 0, a sphere's centre and its radius."""
    shape = next(m for m in model.kinematics.shapes if m.link == link)
    if shape.geometry == "sphere":
        return shape.origin[None, :3, 3].copy(), float(shape.size[0])
    hull = link_hull(model, link)
    return hull.points[hull.vertices], 0.0


def link_hull(model: ArmModel, link: str) -> ConvexHull:
    """The convex hull of a link's collision shape (a mesh or a box), in the link frame."""
    return ConvexHull(shape_points(next(m for m in model.kinematics.shapes if m.link == link)))


def _grid(hull: ConvexHull, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """A grid over the hull's bounding box and each point's signed distance beyond the hull's
    farthest face plane (negative: inside), in blocks (a big link's grid has millions of points)."""
    lo, hi = hull.min_bound, hull.max_bound
    axes = [np.arange(lo[d], hi[d] + spacing, spacing) for d in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    beyond = np.concatenate(
        [
            (b @ hull.equations[:, :3].T + hull.equations[:, 3]).max(axis=1)
            for b in np.array_split(grid, 1 + len(grid) // 50_000)
        ]
    )
    return grid, beyond


def hull_points(hull: ConvexHull, spacing: float) -> np.ndarray:
    """Points of the hull (vertices, a triangular grid on each face, a grid inside) such
    that every point of the hull lies within `spacing` of one of them."""
    pts = [hull.points[hull.vertices]]
    for tri in hull.simplices:
        a, b, c = hull.points[tri]
        longest = max(np.linalg.norm(b - a), np.linalg.norm(c - b), np.linalg.norm(a - c))
        m = max(1, math.ceil(longest / spacing))
        i, j = np.meshgrid(np.arange(m + 1), np.arange(m + 1), indexing="ij")
        keep = i + j <= m
        u, v = i[keep] / m, j[keep] / m
        pts.append(a + u[:, None] * (b - a) + v[:, None] * (c - a))
    grid, beyond = _grid(hull, spacing)
    pts.append(grid[beyond <= 0])
    return np.concatenate(pts)


def candidates(hull: ConvexHull, reach: float, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Balls centred on an interior grid, each reaching `reach` beyond the hull: a ball's
    radius is its centre's depth inside the hull plus `reach`."""
    grid, beyond = _grid(hull, spacing)
    depth = -beyond
    return grid[depth > 0], depth[depth > 0] + reach


@njit(cache=True)
def _holds(centres, radii, points):
    """holds[i, p]: ball i (centre, radius) holds point p. Compiled: numpy's broadcast form
    made a (balls x points x 3) temporary, most of a small link's covering time. The sum is
    numpy's own order ((dx^2 + dy^2) + dz^2), so every answer is the numpy form's, bit for bit
    (a point on a ball's surface included as it was: the shipped sets are unchanged)."""
    out = np.empty((centres.shape[0], points.shape[0]), np.bool_)
    for i in range(centres.shape[0]):
        cx, cy, cz, r2 = centres[i, 0], centres[i, 1], centres[i, 2], radii[i] * radii[i]
        for p in range(points.shape[0]):
            dx, dy, dz = cx - points[p, 0], cy - points[p, 1], cz - points[p, 2]
            out[i, p] = (dx * dx + dy * dy) + dz * dz <= r2
    return out


@njit(cache=True)
def _greedy(holds):
    """The greedy set cover of the points by the balls (holds: _holds): each pick the ball
    holding the most points not yet held (the first such: numpy's argmax), until none holds
    one. Returns the picks and the points left open (a sharp corner, a small reach). Each
    ball's count of open points is kept current, not recounted per pick."""
    n, m = holds.shape
    counts = np.zeros(n, np.int64)
    for i in range(n):
        for p in range(m):
            counts[i] += holds[i, p]
    open_ = np.ones(m, np.bool_)
    newly = np.empty(m, np.int64)
    chosen = []
    while True:
        j = np.argmax(counts)
        if counts[j] == 0:
            break
        chosen.append(j)
        k = 0
        for p in range(m):
            if open_[p] and holds[j, p]:
                open_[p] = False
                newly[k] = p
                k += 1
        for i in range(n):
            if counts[i] == 0:  # holds no open point, so none of these
                continue
            t = 0
            for q in range(k):
                t += holds[i, newly[q]]
            counts[i] -= t
    return np.array(chosen, np.int64), open_


@njit(cache=True)
def _farthest_assigned(points, centres, radii):
    """Each point assigned to the ball it overshoots least (distance minus radius; the first
    such), and per ball its farthest assigned point's distance (-1: none). Compiled, in numpy's
    own arithmetic (a millions-of-points x balls temporary before, most of a link's time)."""
    farthest = np.full(centres.shape[0], -1.0)
    for p in range(points.shape[0]):
        best, owner, dist = np.inf, -1, 0.0
        for i in range(centres.shape[0]):
            dx, dy, dz = points[p, 0] - centres[i, 0], points[p, 1] - centres[i, 1], points[p, 2] - centres[i, 2]
            d = math.sqrt((dx * dx + dy * dy) + dz * dz)
            if d - radii[i] < best:
                best, owner, dist = d - radii[i], i, d
        if owner >= 0 and dist > farthest[owner]:
            farthest[owner] = dist
    return farthest


def cover(points: np.ndarray, hull: ConvexHull, reach: float, seed: int, subsample: int = 6000):
    """Spheres (centres, radii) whose union holds every point, none reaching much beyond
    the hull: a greedy set cover of a subsample by the candidate balls (each pick the ball
    holding the most points not yet held), then every point assigned to the chosen ball it
    overshoots least and each radius set to its farthest assigned point."""
    rng = np.random.default_rng(seed)
    centres, radii = candidates(hull, reach, CANDIDATE_SPACING)
    sub = points[rng.choice(len(points), min(subsample, len(points)), replace=False)]
    holds = _holds(centres, radii, sub)
    chosen, open_ = _greedy(holds)
    c, r = centres[chosen], radii[chosen]
    corner = []  # balls of radius `reach` centred on the points left, each taking those it holds
    while open_.any():
        at = sub[int(np.argmax(open_))]
        corner.append(at)
        open_ &= ((sub - at) ** 2).sum(-1) > reach**2
    if corner:
        c, r = np.concatenate([c, corner]), np.concatenate([r, np.full(len(corner), reach)])
    farthest = _farthest_assigned(points, np.asarray(c, float), np.asarray(r, float))
    keep = farthest >= 0
    return c[keep], farthest[keep]


def spherize(
    model: ArmModel,
    reach: dict[str, float],
    spacing: float,
    pad: float,
    seed: int = 0,
) -> dict:
    """The model's sphere set as a JSON-ready dict: per link, spheres [x, y, z, r] in the link
    frame, with how it was made. A sphere primitive is its own sphere (exact: no sampling gap to
    pad, and Bullet gives a sphere no margin beyond its radius)."""
    if pad <= spacing:
        raise ValueError(f"pad ({pad}) must exceed the sample spacing ({spacing})")
    links = {}
    sources = {}
    for shape in model.kinematics.shapes:
        if shape.link not in reach:  # a partial rebuild (the tests rebuild the small links)
            continue
        if shape.geometry == "sphere":
            centre = shape.origin[:3, 3]
            links[shape.link] = [[*map(float, centre), float(shape.size[0])]]
            sources[shape.link] = {"sphere": float(shape.size[0])}
            continue
        hull = ConvexHull(shape_points(shape))
        points = hull_points(hull, spacing)
        centres, radii = cover(points, hull, reach[shape.link], seed)
        links[shape.link] = [[*map(float, c), float(r + pad)] for c, r in zip(centres, radii)]
        if shape.geometry == "mesh":
            digest = hashlib.sha256(shape.path.read_bytes()).hexdigest()
            sources[shape.link] = {"mesh": shape.path.name, "sha256": digest, "hull_volume": float(hull.volume)}
        else:
            sources[shape.link] = {shape.geometry: list(shape.size), "hull_volume": float(hull.volume)}
    return {
        "robot": model.name,
        "urdf": model.urdf,
        # The module's name before issue 44's layout (now mpnet.envs.arm.spherize), kept: this text
        # is in the shipped sphere file, which every arm cache key and logged model digest hashes.
        "method": (
            "covering of each collision mesh's convex hull (mpnet.envs.spherize): hull points at most "
            "`spacing` apart (vertices, face grids, interior grid), greedily covered by balls centred "
            "inside the hull reaching at most `reach` beyond it, every point then held by the ball it "
            "overshoots least, every radius padded by `pad`"
        ),
        "spacing": spacing,
        "pad": pad,
        "seed": seed,
        "reach": reach,
        "meshes": sources,
        "links": links,
    }
