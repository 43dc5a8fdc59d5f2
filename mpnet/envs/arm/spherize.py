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


def cover(points: np.ndarray, hull: ConvexHull, reach: float, seed: int, subsample: int = 6000):
    """Spheres (centres, radii) whose union holds every point, none reaching much beyond
    the hull: a greedy set cover of a subsample by the candidate balls (each pick the ball
    holding the most points not yet held), then every point assigned to the chosen ball it
    overshoots least and each radius set to its farthest assigned point."""
    rng = np.random.default_rng(seed)
    centres, radii = candidates(hull, reach, CANDIDATE_SPACING)
    sub = points[rng.choice(len(points), min(subsample, len(points)), replace=False)]
    holds = np.concatenate(
        [
            ((c[:, None, :] - sub[None]) ** 2).sum(-1) <= r[:, None] ** 2
            for c, r in zip(
                np.array_split(centres, 1 + len(centres) // 1000), np.array_split(radii, 1 + len(radii) // 1000)
            )
        ]
    )
    open_, chosen = np.ones(len(sub), bool), []
    counts = holds.sum(axis=1)  # per ball, the open points it holds: kept current, not recounted per pick
    while open_.any():
        j = int(np.argmax(counts))
        if counts[j] == 0:  # what is left, no candidate reaches (a sharp corner, a small reach)
            break
        chosen.append(j)
        newly = open_ & holds[j]
        open_ &= ~holds[j]
        counts -= holds[:, newly].sum(axis=1)
    c, r = centres[chosen], radii[chosen]
    corner = []  # balls of radius `reach` centred on the points left, each taking those it holds
    while open_.any():
        at = sub[int(np.argmax(open_))]
        corner.append(at)
        open_ &= ((sub - at) ** 2).sum(-1) > reach**2
    if corner:
        c, r = np.concatenate([c, corner]), np.concatenate([r, np.full(len(corner), reach)])
    farthest = np.full(len(c), -1.0)  # per chosen ball, its farthest assigned point (-1: none)
    for block in np.array_split(points, 1 + len(points) // 100_000):  # bounded memory on big links
        d = np.sqrt(((block[:, None, :] - c[None]) ** 2).sum(-1))
        owner = np.argmin(d - r[None], axis=1)
        np.maximum.at(farthest, owner, d[np.arange(len(block)), owner])
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
