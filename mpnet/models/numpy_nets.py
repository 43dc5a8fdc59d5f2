"""MPNet's networks for planning, in numpy: no torch needed (importing it costs a run ~1.5 s).

- :class:`Normalizer` maps states (and point clouds) into roughly [-1, 1] by a per-dimension
  scale (numpy arrays, and torch tensors when torch is in use).
- :class:`NumpyPnet` / :class:`NumpyEnet` do a Pnet's / an Enet's math with plain matmuls
  (batch 1 is the planner's case), from a torch module (:mod:`mpnet.models.networks`) or from
  a checkpoint's arrays (:mod:`mpnet.models.torch_zip`, :class:`PnetArrays`, :class:`EnetArrays`).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


def _is_tensor(x) -> bool:
    """A torch tensor? Only if torch is imported: nothing else can have made one."""
    torch = sys.modules.get("torch")
    return torch is not None and isinstance(x, torch.Tensor)


class Normalizer:
    """Divide by a per-dimension scale (and multiply back).

    ``scale`` has one entry per state dimension (rigid: ``[20, 20, pi]``), or one entry for
    all. An array whose last dimension is a multiple of ``len(scale)`` is taken as flattened
    points (point-major: ``x0, y0, x1, y1, ...``) and the scale is tiled, so the same object
    normalises a state, a batch of states, or a flattened point cloud. Works on numpy arrays
    (keeping a float dtype) and torch tensors (on their device and dtype).
    """

    def __init__(self, scale: Sequence[float] | float, offset: Sequence[float] | None = None):
        s = np.atleast_1d(np.asarray(scale, dtype=np.float64)).reshape(-1)
        if s.size == 0 or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ValueError(f"scale must be finite and positive, got {scale!r}")
        self.scale = s
        self.offset = None  # subtracted before the scale (a centred normaliser: a bounded Pnet's states)
        if offset is not None:
            o = np.atleast_1d(np.asarray(offset, dtype=np.float64)).reshape(-1)
            if o.size != s.size or not np.all(np.isfinite(o)):
                raise ValueError(f"offset must be finite, one per scale ({s.size}), got {offset!r}")
            self.offset = o if np.any(o != 0) else None
        self._cache: dict[tuple, Any] = {}

    @classmethod
    def centred(cls, bounds: Sequence[Sequence[float]]) -> Normalizer:
        """The bounds onto [-1, 1] exactly: offset the centre, scale the half range (what a
        bounded Pnet's output, in (-1, 1), needs to stay inside the bounds)."""
        lo, hi = (np.array([float(b[i]) for b in bounds]) for i in (0, 1))
        return cls((hi - lo) / 2.0, (hi + lo) / 2.0)

    @classmethod
    def from_bounds(cls, bounds: Sequence[Sequence[float]]) -> Normalizer:
        """Scale = the largest absolute bound per dimension: ``[-20, 20]^2 x [-pi, pi)`` gives
        ``[20, 20, pi]``."""
        return cls([max(abs(float(lo)), abs(float(hi))) for lo, hi in bounds])

    @classmethod
    def points(cls, dim: int, half_extent: float = 20.0) -> Normalizer:
        return cls([half_extent] * dim)

    def to_list(self) -> list[float]:
        return [float(v) for v in self.scale]

    def offset_list(self) -> list[float] | None:
        return None if self.offset is None else [float(v) for v in self.offset]

    def __repr__(self) -> str:
        off = "" if self.offset is None else f", offset={self.offset_list()}"
        return f"Normalizer({self.to_list()}{off})"

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, Normalizer)
            and np.array_equal(self.scale, other.scale)
            and (self.offset is None) == (other.offset is None)
            and (self.offset is None or np.array_equal(self.offset, other.offset))
        )

    def _scale_for(self, x, which: str = "scale"):
        d = x.shape[-1] if x.ndim else 1
        n = self.scale.size
        if n != 1 and d % n:
            raise ValueError(f"last dimension {d} is not a multiple of the scale's {n}")
        if _is_tensor(x):
            key = (which, d, x.dtype, x.device)
        else:
            key = (which, d, x.dtype if np.issubdtype(x.dtype, np.floating) else np.float64)
        s = self._cache.get(key)
        if s is None:
            s = getattr(self, which)
            s = s if n == 1 or d == n else np.tile(s, d // n)
            s = sys.modules["torch"].as_tensor(s, dtype=key[2], device=key[3]) if len(key) == 4 else s.astype(key[2])
            self._cache[key] = s
        return s

    def normalize(self, x):
        x = x if _is_tensor(x) else np.asarray(x)
        if self.offset is not None:
            x = x - self._scale_for(x, "offset")
        return x / self._scale_for(x)

    def denormalize(self, x):
        x = x if _is_tensor(x) else np.asarray(x)
        if self.offset is not None:
            return x * self._scale_for(x) + self._scale_for(x, "offset")
        return x * self._scale_for(x)


# ---------------------------------------------------------------------------------------
# numpy export: the same math with plain matmuls (batch 1, paper s2D: ~1.4x faster than
# eager torch here; the 3.8 M float32 weights (15 MB) read per step set the floor, ~0.28 ms)


def _np(t) -> np.ndarray:
    """A weight as a float32 array of its own: from a torch tensor, or an array already."""
    if _is_tensor(t):
        return t.detach().to("cpu", sys.modules["torch"].float32).numpy().copy()
    return np.array(t, dtype=np.float32)


class NumpyPnet:
    """A Pnet's weights as float32 numpy arrays; call ``step(z, x, goal, rng)``.

    ``rng`` is an ``np.random.Generator`` (dropout on: one draw of all masks per step) or
    ``None`` (dropout off: the same output as ``Pnet.forward(..., stochastic=False)``). With
    a ``normalizer``, ``x`` and ``goal`` are raw states and the result is a raw state;
    without one they are already normalised. One state (1-D inputs, the planner's case)
    runs on buffers allocated once, so an instance is not thread-safe (one per thread);
    2-D inputs (a batch, one dropout mask per row) allocate as usual.
    """

    def __init__(self, pnet, normalizer: Normalizer | None = None):
        self.weights = [np.ascontiguousarray(_np(lin.weight).T) for lin in pnet.linears]
        self.biases = [_np(lin.bias) for lin in pnet.linears]
        alphas = [_np(act.weight) for act in pnet.acts]
        if any(a.size != 1 for a in alphas):
            raise ValueError("numpy export supports single-parameter PReLU only")
        self.alphas = [np.float32(a.item()) for a in alphas]
        # PReLU(h) == max(h, a * h) when 0 <= a <= 1 (cheaper than a select)
        self._prelu_max = all(0.0 <= a <= 1.0 for a in self.alphas)
        self.p = pnet.p
        self.keep_scale = np.float32(1.0 / (1.0 - pnet.p))
        self.n_dropout = pnet.n_dropout if pnet.p > 0 else 0
        widths = [w.shape[1] for w in self.weights[: self.n_dropout]]
        self._offsets = np.concatenate(([0], np.cumsum(widths))).astype(int).tolist()
        self.n_mask = self._offsets[-1]
        # Dropout's 1/(1-p) scale folded into the weights after each dropout layer when it is a
        # power of two (p = 0.5: 2): scaling by 2 is exact, so the step's result is bit for bit
        # the same as scaling the mask, with one operation fewer and a bool mask.
        self._fold = self.n_mask > 0 and math.frexp(float(self.keep_scale))[0] == 0.5
        self._dropout_weights = [
            w * self.keep_scale if self._fold and 0 < i <= self.n_dropout else w for i, w in enumerate(self.weights)
        ]
        self._mask = np.empty(self.n_mask, np.float32)
        self._mask_views = [self._mask[a:b] for a, b in zip(self._offsets[:-1], self._offsets[1:])]
        self._alpha0 = [np.array(a, np.float32) for a in self.alphas]  # a 0-d array multiplies faster than a scalar
        self.in_dim, self.out_dim = pnet.in_dim, pnet.out_dim
        self.state_dim = pnet.out_dim
        self.bounded = bool(getattr(pnet, "bounded", False))  # softsign on the output (Pnet's docstring)
        self.normalizer = normalizer
        if normalizer is not None:
            if normalizer.scale.size not in (1, self.out_dim):
                raise ValueError(f"normalizer has {normalizer.scale.size} scales, Pnet outputs {self.out_dim}")
            self._inv = (1.0 / normalizer.scale).astype(np.float32)
            # scales x and goal at once in the one-state path
            self._inv2 = np.tile(np.broadcast_to(self._inv, (self.out_dim,)), 2)
            self._out = normalizer.scale.astype(np.float64)
            offset = np.zeros(self.out_dim) if normalizer.offset is None else normalizer.offset
            self._shift = np.broadcast_to(offset, (self.out_dim,)).astype(np.float32)  # x and goal's
            self._shift2 = np.tile(self._shift, 2)
            self._out_off = np.broadcast_to(offset, (self.out_dim,)).astype(np.float64)
            self._centred = normalizer.offset is not None
        # buffers of the one-state path
        self._in = np.empty(self.in_dim, np.float32)
        self._bufs = [np.empty(w.shape[1], np.float32) for w in self.weights]
        self._tmps = [np.empty(w.shape[1], np.float32) for w in self.weights[:-1]]
        self._zdim = self.in_dim - 2 * self.state_dim

    def __call__(self, z, x, goal, rng: np.random.Generator | None = None) -> np.ndarray:
        return self.step(z, x, goal, rng)

    def step(self, z, x, goal, rng: np.random.Generator | None = None) -> np.ndarray:
        x = np.asarray(x)
        if x.ndim == 1:
            return self._step1(z, x, goal, rng)
        return self._step_batch(z, x, goal, rng)

    def _step1(self, z, x, goal, rng) -> np.ndarray:
        h = self._in
        zd, d = self._zdim, self.state_dim
        if np.shape(z) != (zd,) or np.shape(x) != (d,) or np.shape(goal) != (d,):
            raise ValueError(
                f"expected z ({zd},), x and goal ({d},); got {np.shape(z)}, {np.shape(x)}, {np.shape(goal)}"
            )
        h[:zd] = z
        h[zd : zd + d] = x
        h[zd + d :] = goal
        if self.normalizer is not None:
            if self._centred:
                h[zd:] -= self._shift2
            h[zd:] *= self._inv2
        masks, weights = None, self.weights
        if rng is not None and self.n_mask:
            masks = np.greater_equal(rng.random(self.n_mask, dtype=np.float32), self.p, out=self._mask)
            if self._fold:
                weights = self._dropout_weights
            else:
                masks *= self.keep_scale
        last = len(weights) - 1
        for i, (w, b) in enumerate(zip(weights, self.biases)):
            o = self._bufs[i]
            np.dot(h, w, out=o)  # np.dot: the same BLAS call as matmul, less overhead at batch 1
            o += b
            if i == last:
                break
            t = self._tmps[i]
            if self._prelu_max:
                np.multiply(o, self._alpha0[i], out=t)
                np.maximum(o, t, out=o)
            else:
                np.less(o, 0, out=t)
                t *= self.alphas[i] - 1.0
                t += 1.0
                o *= t
            if masks is not None and i < self.n_dropout:
                o *= self._mask_views[i]
            h = o
        return self._output(o)

    def _output(self, o: np.ndarray) -> np.ndarray:
        """The last layer's float32 output -> the step's result (float64 where a normaliser
        maps it back): softsign if bounded, then scale and offset, as the compiled kernel."""
        if self.normalizer is None:
            return o / (np.float32(1.0) + np.abs(o)) if self.bounded else o.copy()
        v = o.astype(np.float64)
        if self.bounded:
            v = v / (1.0 + np.abs(v))
        v = v * self._out
        if self._centred:
            v += self._out_off
        return v

    def _step_batch(self, z, x, goal, rng) -> np.ndarray:
        z = np.asarray(z, dtype=np.float32)
        x = np.asarray(x, dtype=np.float32)
        goal = np.asarray(goal, dtype=np.float32)
        if self.normalizer is not None:
            if self._centred:
                x, goal = x - self._shift, goal - self._shift
            x = x * self._inv
            goal = goal * self._inv
        if z.ndim < x.ndim:
            z = np.broadcast_to(z, x.shape[:-1] + z.shape[-1:])
        h = np.concatenate((z, x, goal), axis=-1)
        if h.shape[-1] != self.in_dim:
            raise ValueError(f"input has {h.shape[-1]} features, Pnet expects {self.in_dim}")
        masks = None
        if rng is not None and self.n_mask:
            u = rng.random(h.shape[:-1] + (self.n_mask,), dtype=np.float32)
            masks = (u >= self.p) * self.keep_scale
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases)):
            h = h @ w
            h += b
            if i == last:
                break
            h = np.where(h >= 0, h, h * self.alphas[i])
            if masks is not None and i < self.n_dropout:
                h *= masks[..., self._offsets[i] : self._offsets[i + 1]]
        return self._output(h)


def _flat_cloud(cloud, in_dim: int):
    """A cloud given as points (n_points, wdim) -> flattened point-major (in_dim,); a
    flattened cloud or a batch (B, in_dim) passes through."""
    if cloud.shape[-1:] == (in_dim,):
        return cloud
    if cloud.ndim == 2 and cloud.shape[0] * cloud.shape[1] == in_dim:
        return cloud.reshape(in_dim)
    raise ValueError(f"cloud of shape {tuple(cloud.shape)} does not fit Enet's input {in_dim}")


class NumpyEnet:
    """An Enet's weights as float32 numpy arrays: ``encode(cloud) -> z`` (cloud already
    normalised unless a ``normalizer`` is given)."""

    def __init__(self, enet, normalizer: Normalizer | None = None):
        lins = enet.linears()
        self.weights = [np.ascontiguousarray(_np(lin.weight).T) for lin in lins]
        self.biases = [_np(lin.bias) for lin in lins]
        self.alphas = [np.float32(_np(a).item()) for a in enet.prelu_weights()]
        self.normalizer = normalizer
        self.in_dim = enet.in_dim

    def __call__(self, cloud) -> np.ndarray:
        return self.encode(cloud)

    def encode(self, cloud) -> np.ndarray:
        """One cloud, flattened (D,) or as points (n_points, wdim), or a batch (B, D)."""
        h = _flat_cloud(np.asarray(cloud, dtype=np.float32), self.in_dim)
        if self.normalizer is not None:
            h = self.normalizer.normalize(h).astype(np.float32, copy=False)
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases)):
            h = h @ w
            h += b
            if i < last:
                h = np.where(h >= 0, h, h * self.alphas[i])
        return h


@dataclass(frozen=True)
class Layer:
    """A linear layer's weight (out, in) and bias, or a PReLU's weight (bias None)."""

    weight: np.ndarray
    bias: np.ndarray | None = None


class PnetArrays:
    """A Pnet as a state dict of arrays gives it (``linears.i.*``, ``acts.i.weight``), with the
    attributes :class:`NumpyPnet` reads from a torch Pnet."""

    def __init__(self, config: dict, state: dict[str, np.ndarray]):
        hidden = [int(h) for h in config["hidden"]]
        self.in_dim, self.out_dim, self.p = int(config["in_dim"]), int(config["out_dim"]), float(config["dropout"])
        self.bounded = bool(config.get("bounded", False))
        self.linears = [Layer(state[f"linears.{i}.weight"], state[f"linears.{i}.bias"]) for i in range(len(hidden) + 1)]
        self.acts = [Layer(state[f"acts.{i}.weight"]) for i in range(len(hidden))]
        self.n_dropout = max(len(hidden) - 1, 0)


class EnetArrays:
    """An Enet as a state dict of arrays gives it (``net.k.*``: linear layers at even k, PReLUs
    between), with the methods :class:`NumpyEnet` calls on a torch Enet."""

    def __init__(self, config: dict, state: dict[str, np.ndarray]):
        n = len(config["hidden"]) + 1
        self.in_dim = int(config["in_dim"])
        self._linears = [Layer(state[f"net.{2 * i}.weight"], state[f"net.{2 * i}.bias"]) for i in range(n)]
        self._alphas = [state[f"net.{2 * i + 1}.weight"] for i in range(n - 1)]

    def linears(self) -> list[Layer]:
        return self._linears

    def prelu_weights(self) -> list[np.ndarray]:
        return self._alphas
