"""A voxel grid as Enet's input (a named recipe option, not the paper's): which cells of a grid
over the normalised workspace ([-1, 1) per axis) hold at least one of the cloud's points.

Why: the paper's Enet reads the flattened cloud, so its input k means "the k-th point drawn",
which lands on a different surface in each scene; only the canonical order makes it a function
of the geometry at all. A cell's occupancy means one place in every scene, whatever order or
number the points come in, so Enet's first layer can learn where obstacles are, and the code
generalises across scenes of a family (issue 42: Pnet barely read the point code on the arm).

The cell of a point is floor((p + 1) * cells / 2) per axis, computed in float64 from the float32
normalised point (exact in every implementation: numpy here, the compiled kernel here, torch in
:class:`mpnet.models.networks.Enet`), so all three give the same occupancy, bit for bit. Points
outside the grid (or NaN) are dropped, not clamped: a far obstacle is not smeared onto the border.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mpnet.jit import njit


def grid_cells(voxels: Sequence[int] | None) -> tuple[int, ...] | None:
    """A config's cells per axis, checked: None (no grid), or positive integers."""
    if voxels is None:
        return None
    cells = tuple(int(c) for c in voxels)
    if not cells or any(c < 1 for c in cells) or any(int(c) != c for c in voxels):
        raise ValueError(f"voxels must be cells per axis (integers >= 1), got {list(voxels)}")
    return cells


def n_cells(cells: Sequence[int]) -> int:
    return int(np.prod(cells))


def strides(cells: tuple[int, ...]) -> np.ndarray:
    """Row-major: the first axis slowest."""
    return np.array([int(np.prod(cells[a + 1 :])) for a in range(len(cells))], np.int64)


def occupancy(cloud, cells: Sequence[int]) -> np.ndarray:
    """The occupancy (float32 0/1, (..., prod(cells))) of a normalised cloud: flattened
    point-major (..., n_points * dim) with dim = len(cells)."""
    cells = tuple(cells)
    dim = len(cells)
    x = np.asarray(cloud, dtype=np.float32)
    if x.shape[-1] % dim:
        raise ValueError(f"a cloud of {x.shape[-1]} numbers is not a list of {dim}-D points")
    lead = x.shape[:-1]
    pts = x.reshape(-1, x.shape[-1] // dim, dim).astype(np.float64)
    half = np.asarray(cells, np.float64) / 2.0
    with np.errstate(invalid="ignore"):
        k = np.floor((pts + 1.0) * half)
        inside = np.all((k >= 0) & (k < np.asarray(cells)), axis=-1)
    flat = np.where(inside, (np.where(inside[..., None], k, 0).astype(np.int64) * strides(cells)).sum(-1), -1)
    total = n_cells(cells)
    out = np.zeros((pts.shape[0], total + 1), np.float32)  # the last column takes the dropped points
    rows = np.broadcast_to(np.arange(pts.shape[0])[:, None], flat.shape)
    out[rows, np.where(flat < 0, total, flat)] = 1.0
    return out[:, :total].reshape(*lead, total)


@njit(cache=True)
def occupancy_into(h, cells, out):
    """occupancy() of one flattened normalised float32 cloud h into out (float32, zeroed here)."""
    dim = cells.shape[0]
    out[:] = 0.0
    for i in range(h.shape[0] // dim):
        flat = 0
        inside = True
        for a in range(dim):
            k = np.floor((np.float64(h[i * dim + a]) + 1.0) * (np.float64(cells[a]) / 2.0))
            if not (k >= 0.0 and k < cells[a]):  # NaN fails too
                inside = False
                break
            flat = flat * cells[a] + np.int64(k)
        if inside:
            out[flat] = 1.0


__all__ = ["grid_cells", "n_cells", "occupancy", "occupancy_into", "strides"]
