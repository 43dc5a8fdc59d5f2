"""Enet's encoding compiled (numba), for the compiled planner: NumpyEnet.encode's operations in
the same order and precision (the cloud divided by the tiled scale, then each layer's np.dot,
the same BLAS sgemv numpy's `@` calls, its bias and PReLU), so the same bits.

Why: an encoding is a few matrix-vector products, the first reading Enet's largest matrix
(2-D: 2800 x 512); numpy adds a division, a temporary per layer and np.where's three arrays,
each a pass over memory the products already made cold. Compiled, one pass per layer into
buffers kept between queries.
"""

from __future__ import annotations

import numpy as np

from mpnet.jit import njit
from mpnet.models.numpy_nets import NumpyEnet, _flat_cloud
from mpnet.models.pnet_kernel import affine
from mpnet.models.voxels import n_cells, occupancy_into


class EnetKernel:
    """A NumpyEnet's arrays as the kernel takes them; `encode(cloud) -> z` with NumpyEnet's
    meaning (one cloud, flattened or as points; a new array each call; a voxel Enet's grid
    filled by mpnet.models.voxels.occupancy_into)."""

    def __init__(self, enet: NumpyEnet):
        if any(w.shape[1] == 1 for w in enet.weights):  # numpy takes a dot product there: other sums
            raise ValueError("the compiled encoding needs every layer at least 2 wide")
        self.in_dim = enet.in_dim
        self.weights = tuple(np.ascontiguousarray(w, np.float32) for w in enet.weights)
        self.biases = tuple(np.ascontiguousarray(b, np.float32) for b in enet.biases)
        self.alphas = np.asarray(enet.alphas, np.float32).reshape(len(enet.alphas))
        dummy = np.empty(self.in_dim, np.float32)
        scale = None if enet.normalizer is None else enet.normalizer._scale_for(dummy)  # one entry: broadcast
        self.scale = None if scale is None else np.ascontiguousarray(np.broadcast_to(scale, self.in_dim), np.float32)
        self.voxels = None if enet.voxels is None else np.asarray(enet.voxels, np.int64)
        self._h = np.empty(self.in_dim, np.float32)
        self._grid = None if enet.voxels is None else np.empty(n_cells(enet.voxels), np.float32)
        self._layers = tuple(np.empty(w.shape[1], np.float32) for w in self.weights)

    def encode(self, cloud) -> np.ndarray:
        x = _flat_cloud(np.asarray(cloud, dtype=np.float32), self.in_dim)
        if x.ndim != 1:
            raise ValueError(f"the compiled encoding takes one cloud, got shape {tuple(x.shape)}")
        x = np.ascontiguousarray(x)
        if self.scale is None:
            self._h[:] = x
        else:
            _divide(x, self.scale, self._h)
        h = self._h
        if self.voxels is not None:
            occupancy_into(h, self.voxels, self._grid)
            h = self._grid
        return enet_encode(h, self.weights, self.biases, self.alphas, self._layers)

    __call__ = encode


@njit(cache=True)
def _divide(x, scale, out):
    """Normalizer.normalize of a float32 cloud: x / scale, element by element."""
    for i in range(x.shape[0]):
        out[i] = x[i] / scale[i]


@njit(cache=True)
def enet_encode(h, weights, biases, alphas, layers):
    """z = Enet(h), h normalised: each layer h @ w + b, PReLU between (np.where(h >= 0, h, h * a))."""
    last = len(weights) - 1
    src = h
    for k in range(last + 1):
        o = layers[k]
        affine(src, weights[k], biases[k], o)
        if k < last:
            a = alphas[k]
            for j in range(o.shape[0]):
                v = o[j]
                o[j] = v if v >= 0 else v * a
        src = o
    return layers[last].copy()
