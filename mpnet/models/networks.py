"""MPNet's two networks as plain ``torch.nn`` modules (no Lightning here).

- :class:`Enet` encodes an obstacle point cloud (flattened, point-major: x0, y0, x1, y1, ...)
  into a latent ``Z``; :class:`Decoder` mirrors it; :class:`ContractiveAE` trains the pair
  with reconstruction MSE + ``lam * sum(W_enc^2)``.
- :class:`Pnet` maps ``cat(Z, x_t, x_goal)`` to ``x_{t+1}``, with PReLU after every hidden
  layer and dropout after every hidden layer but the last one. Dropout is controlled by the
  ``stochastic`` argument, never by the module's train/eval state, so a planner keeps it on
  under ``torch.inference_mode``.
- :func:`pnet_numpy` / :func:`enet_numpy` export the weights to numpy callables that do the
  same math without torch's per-call overhead (batch 1 is the planner's case); they and
  :class:`Normalizer` live in :mod:`mpnet.models.numpy_nets`, which needs no torch.

Every network has ``config()`` (a plain dict of its constructor arguments) so that it can be
rebuilt with ``Cls(**config)``; the LightningModules save only these dicts.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from mpnet.models.numpy_nets import Normalizer, NumpyEnet, NumpyPnet, _flat_cloud  # noqa: F401 (re-exported)

# The public MPNet code's sizes for simple 2D (ahq1993/MPNet; conf/scale/paper.yaml sets them).
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

    def prelu_weights(self) -> list[torch.Tensor]:
        return [m.weight for m in self.net if isinstance(m, nn.PReLU)]

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

    ``bounded`` (a named recipe option, not the paper's): the output passes through softsign,
    ``x / (1 + |x|)``, into (-1, 1), which a centred normaliser maps inside the state bounds:
    no proposal leaves the joint limits. Softsign, not tanh: its division and absolute value
    are exact IEEE operations, so numpy and the compiled kernel give the same bits.
    """

    def __init__(
        self,
        in_dim: int,
        out_dim: int,
        hidden: Sequence[int] = PNET_HIDDEN,
        dropout: float = 0.5,
        bounded: bool = False,
    ):
        super().__init__()
        self.bounded = bool(bounded)
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
        x = self.linears[-1](x)
        return F.softsign(x) if self.bounded else x

    def step(self, z: torch.Tensor, x_t: torch.Tensor, x_goal: torch.Tensor, stochastic: bool = True) -> torch.Tensor:
        """Convenience: ``forward(cat(z, x_t, x_goal))`` along the last dimension."""
        return self(torch.cat((z, x_t, x_goal), dim=-1), stochastic)

    def config(self) -> dict[str, Any]:
        out = {"in_dim": self.in_dim, "out_dim": self.out_dim, "hidden": list(self.hidden), "dropout": self.p}
        return out | {"bounded": True} if self.bounded else out  # absent: the configs saved before it


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
