"""MPNet's two networks as plain ``torch.nn`` modules (no Lightning here).

- :class:`Enet` encodes an obstacle point cloud (flattened, point-major: x0, y0, x1, y1, ...)
  into a latent ``Z``; :class:`Decoder` mirrors it; :class:`ContractiveAE` trains the pair
  with reconstruction MSE + ``lam * sum(W_enc^2)``.
- :class:`Pnet` maps ``cat(Z, x_t, x_goal)`` to ``x_{t+1}``, with PReLU after every hidden
  layer and dropout after every hidden layer but the last one. Dropout is controlled by the
  ``stochastic`` argument, never by the module's train/eval state, so a planner keeps it on
  under ``torch.inference_mode``.
- :class:`Normalizer` maps states (and point clouds) into roughly [-1, 1] by a per-dimension
  scale.
- :func:`pnet_numpy` / :func:`enet_numpy` export the weights to numpy callables that do the
  same math without torch's per-call overhead (batch 1 is the planner's case).

Every network has ``config()`` (a plain dict of its constructor arguments) so that it can be
rebuilt with ``Cls(**config)``; the LightningModules save only these dicts.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

# The public MPNet code's sizes for simple 2D (DESIGN §1).
ENET_HIDDEN = (512, 256, 128)
ENET_LATENT = 28
PNET_HIDDEN = (1280, 1024, 896, 768, 512, 384, 256, 256, 128, 64, 32)


def _ints(xs: Sequence[int], what: str) -> tuple[int, ...]:
    out = tuple(int(x) for x in xs)
    if any(x <= 0 for x in out):
        raise ValueError(f"{what} must be positive integers, got {list(xs)}")
    return out


def _mlp(sizes: Sequence[int]) -> nn.Sequential:
    """Linear layers with a (single-parameter) PReLU between them, none after the last."""
    layers: list[nn.Module] = []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        layers.append(nn.Linear(a, b))
        if i < len(sizes) - 2:
            layers.append(nn.PReLU())
    return nn.Sequential(*layers)


class Enet(nn.Module):
    """Encoder: ``in_dim -> hidden... -> latent`` (s2D: 2800 -> 512 -> 256 -> 128 -> 28)."""

    def __init__(self, in_dim: int, hidden: Sequence[int] = ENET_HIDDEN, latent: int = ENET_LATENT):
        super().__init__()
        self.in_dim = _ints([in_dim], "in_dim")[0]
        self.hidden = _ints(hidden, "hidden")
        self.latent = _ints([latent], "latent")[0]
        self.net = _mlp((self.in_dim, *self.hidden, self.latent))

    def forward(self, cloud: torch.Tensor) -> torch.Tensor:
        return self.net(cloud)

    def linears(self) -> list[nn.Linear]:
        return [m for m in self.net if isinstance(m, nn.Linear)]

    def config(self) -> dict[str, Any]:
        return {"in_dim": self.in_dim, "hidden": list(self.hidden), "latent": self.latent}


class Decoder(nn.Module):
    """The encoder's mirror. Takes the ENCODER's arguments (``Decoder(**enet.config())``):
    ``latent -> reversed(hidden)... -> out_dim`` (s2D: 28 -> 128 -> 256 -> 512 -> 2800)."""

    def __init__(self, out_dim: int, hidden: Sequence[int] = ENET_HIDDEN, latent: int = ENET_LATENT):
        super().__init__()
        self.out_dim = _ints([out_dim], "out_dim")[0]
        self.hidden = _ints(hidden, "hidden")
        self.latent = _ints([latent], "latent")[0]
        self.net = _mlp((self.latent, *reversed(self.hidden), self.out_dim))

    @classmethod
    def mirror(cls, encoder: Enet) -> Decoder:
        return cls(encoder.in_dim, encoder.hidden, encoder.latent)

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        return self.net(z)

    def config(self) -> dict[str, Any]:
        return {"out_dim": self.out_dim, "hidden": list(self.hidden), "latent": self.latent}


class ContractiveAE(nn.Module):
    """Encoder + decoder trained with ``MSE(x, x_hat) + lam * sum(W_enc^2)``.

    The penalty sums the squared weights (not biases) of every Linear layer of the encoder,
    as the paper's Eq. 1 (the public code penalised only the encoder's last weight matrix,
    through a detached copy, so there it did not reach the gradient).
    """

    def __init__(self, encoder: Enet, decoder: Decoder, lam: float = 1e-3):
        super().__init__()
        if decoder.out_dim != encoder.in_dim or decoder.latent != encoder.latent:
            raise ValueError(
                f"decoder {decoder.latent}->{decoder.out_dim} does not mirror encoder "
                f"{encoder.in_dim}->{encoder.latent}"
            )
        self.encoder = encoder
        self.decoder = decoder
        self.lam = float(lam)

    @classmethod
    def from_config(cls, config: dict[str, Any]) -> ContractiveAE:
        return cls(Enet(**config["encoder"]), Decoder(**config["decoder"]), config.get("lam", 1e-3))

    def config(self) -> dict[str, Any]:
        return {"encoder": self.encoder.config(), "decoder": self.decoder.config(), "lam": self.lam}

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.decoder(self.encoder(x))

    def penalty(self) -> torch.Tensor:
        return self.lam * sum(lin.weight.pow(2).sum() for lin in self.encoder.linears())

    def loss(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """``(total, recon_mse, penalty)``; ``recon_mse`` is the mean over all elements."""
        recon = F.mse_loss(self(x), x)
        pen = self.penalty()
        return recon + pen, recon, pen


class Pnet(nn.Module):
    """Planning network: ``cat(Z, x_t, x_goal) -> x_{t+1}``.

    Linear layers ``in_dim -> hidden... -> out_dim``; PReLU after each hidden layer; dropout
    with probability ``dropout`` after every hidden layer except the last hidden one (the
    paper's "all hidden layers except the last one"; s2D: not after 64 -> 32).
    ``in_dim = latent + 2 * state_dim``.
    """

    def __init__(self, in_dim: int, out_dim: int, hidden: Sequence[int] = PNET_HIDDEN, dropout: float = 0.5):
        super().__init__()
        self.in_dim = _ints([in_dim], "in_dim")[0]
        self.out_dim = _ints([out_dim], "out_dim")[0]
        self.hidden = _ints(hidden, "hidden")
        if not 0.0 <= float(dropout) < 1.0:
            raise ValueError(f"dropout must be in [0, 1), got {dropout}")
        self.p = float(dropout)
        sizes = (self.in_dim, *self.hidden, self.out_dim)
        self.linears = nn.ModuleList(nn.Linear(a, b) for a, b in zip(sizes[:-1], sizes[1:]))
        self.acts = nn.ModuleList(nn.PReLU() for _ in self.hidden)
        # dropout after hidden layer i for i < len(hidden) - 1
        self.n_dropout = max(len(self.hidden) - 1, 0)

    def forward(self, x: torch.Tensor, stochastic: bool = True) -> torch.Tensor:
        """``x`` is ``cat(Z, x_t, x_goal)`` (normalised states). ``stochastic`` turns dropout
        on regardless of ``self.training`` (and works under ``torch.inference_mode``)."""
        drop = stochastic and self.p > 0.0
        for i, act in enumerate(self.acts):
            x = act(self.linears[i](x))
            if drop and i < self.n_dropout:
                x = F.dropout(x, self.p, training=True)
        return self.linears[-1](x)

    def step(self, z: torch.Tensor, x_t: torch.Tensor, x_goal: torch.Tensor, stochastic: bool = True) -> torch.Tensor:
        """Convenience: ``forward(cat(z, x_t, x_goal))`` along the last dimension."""
        return self(torch.cat((z, x_t, x_goal), dim=-1), stochastic)

    def config(self) -> dict[str, Any]:
        return {"in_dim": self.in_dim, "out_dim": self.out_dim, "hidden": list(self.hidden), "dropout": self.p}


class Normalizer:
    """Divide by a per-dimension scale (and multiply back).

    ``scale`` has one entry per state dimension (rigid: ``[20, 20, pi]``), or one entry for
    all. An array whose last dimension is a multiple of ``len(scale)`` is taken as flattened
    points (point-major: ``x0, y0, x1, y1, ...``) and the scale is tiled, so the same object
    normalises a state, a batch of states, or a flattened point cloud. Works on numpy arrays
    (keeping a float dtype) and torch tensors (on their device and dtype).
    """

    def __init__(self, scale: Sequence[float] | float):
        s = np.atleast_1d(np.asarray(scale, dtype=np.float64)).reshape(-1)
        if s.size == 0 or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ValueError(f"scale must be finite and positive, got {scale!r}")
        self.scale = s
        self._cache: dict[tuple, Any] = {}

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

    def __repr__(self) -> str:
        return f"Normalizer({self.to_list()})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Normalizer) and np.array_equal(self.scale, other.scale)

    def _scale_for(self, x):
        d = x.shape[-1] if x.ndim else 1
        n = self.scale.size
        if n != 1 and d % n:
            raise ValueError(f"last dimension {d} is not a multiple of the scale's {n}")
        if isinstance(x, torch.Tensor):
            key = (d, x.dtype, x.device)
        else:
            key = (d, x.dtype if np.issubdtype(x.dtype, np.floating) else np.float64)
        s = self._cache.get(key)
        if s is None:
            s = self.scale if n == 1 or d == n else np.tile(self.scale, d // n)
            s = torch.as_tensor(s, dtype=key[1], device=key[2]) if len(key) == 3 else s.astype(key[1])
            self._cache[key] = s
        return s

    def normalize(self, x):
        x = x if isinstance(x, torch.Tensor) else np.asarray(x)
        return x / self._scale_for(x)

    def denormalize(self, x):
        x = x if isinstance(x, torch.Tensor) else np.asarray(x)
        return x * self._scale_for(x)


# ---------------------------------------------------------------------------------------
# numpy export: the same math with plain matmuls (batch 1, paper s2D: ~1.4x faster than
# eager torch here; the 3.8 M float32 weights (15 MB) read per step set the floor, ~0.28 ms)


def _np(t: torch.Tensor) -> np.ndarray:
    return t.detach().to("cpu", torch.float32).numpy().copy()


class NumpyPnet:
    """A Pnet's weights as float32 numpy arrays; call ``step(z, x, goal, rng)``.

    ``rng`` is an ``np.random.Generator`` (dropout on: one draw of all masks per step) or
    ``None`` (dropout off: the same output as ``Pnet.forward(..., stochastic=False)``). With
    a ``normalizer``, ``x`` and ``goal`` are raw states and the result is a raw state;
    without one they are already normalised. One state (1-D inputs, the planner's case)
    runs on buffers allocated once, so an instance is not thread-safe (one per thread);
    2-D inputs (a batch, one dropout mask per row) allocate as usual.
    """

    def __init__(self, pnet: Pnet, normalizer: Normalizer | None = None):
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
        self.normalizer = normalizer
        if normalizer is not None:
            if normalizer.scale.size not in (1, self.out_dim):
                raise ValueError(f"normalizer has {normalizer.scale.size} scales, Pnet outputs {self.out_dim}")
            self._inv = (1.0 / normalizer.scale).astype(np.float32)
            # scales x and goal at once in the one-state path
            self._inv2 = np.tile(np.broadcast_to(self._inv, (self.out_dim,)), 2)
            self._out = normalizer.scale.astype(np.float64)
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
        if self.normalizer is not None:
            return o * self._out
        return o.copy()

    def _step_batch(self, z, x, goal, rng) -> np.ndarray:
        z = np.asarray(z, dtype=np.float32)
        x = np.asarray(x, dtype=np.float32)
        goal = np.asarray(goal, dtype=np.float32)
        if self.normalizer is not None:
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
        if self.normalizer is not None:
            return h * self._out
        return h


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

    def __init__(self, enet: Enet, normalizer: Normalizer | None = None):
        lins = enet.linears()
        self.weights = [np.ascontiguousarray(_np(lin.weight).T) for lin in lins]
        self.biases = [_np(lin.bias) for lin in lins]
        self.alphas = [np.float32(_np(m.weight).item()) for m in enet.net if isinstance(m, nn.PReLU)]
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


def pnet_numpy(pnet: Pnet, normalizer: Normalizer | None = None) -> NumpyPnet:
    """Export a Pnet to a numpy callable ``step(z, x, goal, rng) -> next``."""
    return NumpyPnet(pnet, normalizer)


def enet_numpy(enet: Enet, normalizer: Normalizer | None = None) -> NumpyEnet:
    """Export an Enet to a numpy callable ``encode(cloud) -> z``."""
    return NumpyEnet(enet, normalizer)


def paper_s2d(n_points: int = 1400) -> tuple[Enet, Decoder, Pnet]:
    """The public code's s2D networks: Enet 2800 -> 28, decoder 28 -> 2800, Pnet 32 -> 2."""
    enet = Enet(2 * n_points)
    return enet, Decoder.mirror(enet), Pnet(ENET_LATENT + 2 * 2, 2)


__all__ = [
    "ENET_HIDDEN",
    "ENET_LATENT",
    "PNET_HIDDEN",
    "Enet",
    "Decoder",
    "ContractiveAE",
    "Pnet",
    "Normalizer",
    "NumpyPnet",
    "NumpyEnet",
    "pnet_numpy",
    "enet_numpy",
    "paper_s2d",
]
