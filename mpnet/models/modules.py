"""LightningModules that train MPNet's networks (:mod:`mpnet.models.networks`).

Both modules normalise their inputs themselves (point clouds by the workspace scale, states
by the env's state scale) and save those scales, the networks' constructor arguments and
the optimiser settings as plain dicts, lists and numbers (no nn.Module, no DictConfig), so a
checkpoint is self-contained: ``Cls.load_from_checkpoint(path)`` rebuilds everything under
torch's ``weights_only`` loading, and :func:`mpnet.models.checkpoint.load_pnet_checkpoint`
reads the planner's networks without importing Lightning.

Metrics: ``train_loss`` / ``val_loss`` (per step and per epoch for training), plus
``train_recon``, ``train_penalty``, ``val_recon`` for the autoencoder.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import lightning as L
import numpy as np
import torch
import torch.nn.functional as F

from mpnet.models.networks import ContractiveAE, Enet, Normalizer, Pnet
from mpnet.models.voxels import occupancy

OPTIMIZERS = ("adagrad", "adam")
COLLISION_SHARE = 0.25  # of a batch's samples measured by the collision loss (batch_loss)


def _make_optimizer(name: str, params, lr: float, fused: bool = False) -> torch.optim.Optimizer:
    """The optimiser; `fused`: torch's fused step (one kernel over every parameter: the same
    update, rounded otherwise), about twice as fast a step where Enet's first layer trains."""
    name = name.lower()
    more = {"fused": True} if fused else {}
    if name == "adagrad":
        return torch.optim.Adagrad(params, lr=lr, **more)
    if name == "adam":
        return torch.optim.Adam(params, lr=lr, **more)
    raise ValueError(f"unknown optimizer {name!r}; choices: {', '.join(OPTIMIZERS)}")


class EnetModule(L.LightningModule):
    """Trains a :class:`ContractiveAE` on flattened point clouds (raw workspace coordinates;
    divided by ``cloud_scale`` here). ``ae`` is the autoencoder or its ``config()`` dict;
    ``lam`` (when given) replaces the autoencoder's penalty weight. The public code used
    Adagrad (lr 0.01, its default)."""

    def __init__(
        self,
        ae: ContractiveAE | dict[str, Any],
        lr: float = 1e-2,
        lam: float | None = None,
        optimizer: str = "adagrad",
        *,
        cloud_scale: Sequence[float] | float,
        fused: bool = False,
    ):
        super().__init__()
        ae = ae if isinstance(ae, ContractiveAE) else ContractiveAE.from_config(ae)
        if lam is not None:
            ae.lam = float(lam)
        if optimizer.lower() not in OPTIMIZERS:
            raise ValueError(f"unknown optimizer {optimizer!r}; choices: {', '.join(OPTIMIZERS)}")
        self.ae = ae
        self.cloud_norm = Normalizer(cloud_scale)
        self.save_hyperparameters(
            {
                "ae": ae.config(),
                "lr": float(lr),
                "lam": ae.lam,
                "optimizer": optimizer.lower(),
                "cloud_scale": self.cloud_norm.to_list(),
            }
            | ({"fused": True} if fused else {})
        )

    @property
    def encoder(self) -> Enet:
        return self.ae.encoder

    def forward(self, cloud: torch.Tensor) -> torch.Tensor:
        """Raw cloud -> latent ``Z``."""
        return self.ae.encoder(self.cloud_norm.normalize(cloud))

    def losses(self, batch: torch.Tensor):
        return self.ae.loss(self.cloud_norm.normalize(batch))

    def training_step(self, batch: torch.Tensor, batch_idx: int) -> torch.Tensor:
        total, recon, pen = self.losses(batch)
        n = batch.shape[0]
        self.log("train_loss", total, on_step=True, on_epoch=True, prog_bar=True, batch_size=n)
        self.log("train_recon", recon, on_step=False, on_epoch=True, batch_size=n)
        self.log("train_penalty", pen, on_step=False, on_epoch=True, batch_size=n)
        return total

    def validation_step(self, batch: torch.Tensor, batch_idx: int) -> None:
        total, recon, _ = self.losses(batch)
        n = batch.shape[0]
        self.log("val_loss", total, on_epoch=True, prog_bar=True, batch_size=n)
        self.log("val_recon", recon, on_epoch=True, batch_size=n)

    def configure_optimizers(self):
        h = self.hparams
        return _make_optimizer(h["optimizer"], self.parameters(), h["lr"], h.get("fused", False))


class PnetModule(L.LightningModule):
    """Trains a :class:`Pnet` with MSE between ``Pnet(Z(cloud), x_t, x_goal)`` and
    ``x_next``, all in normalised coordinates.

    ``pnet`` / ``encoder`` are the networks or their ``config()`` dicts. ``Z`` comes from the
    encoder applied to the workspace's cloud; with ``freeze_encoder`` (the paper's choice for
    point-mass and rigid bodies) it gets no gradient and is not optimised; without it Enet
    and Pnet train end to end (the arm). ``state_scale`` and ``cloud_scale`` come from the
    env's bounds (``StateSpace.scale``, ``EnvSpec.workspace_scale``: rigid ``[20, 20, pi]``
    and ``[20, 20]``), never a default that would mis-scale another robot. Training runs Pnet
    with dropout on; validation with dropout off unless ``val_stochastic``.

    Batches are dicts ``{"clouds": (k, D), "ws": (B,) index into clouds, "x_t", "x_goal",
    "x_next": (B, state_dim)}`` (what :class:`MPNetDataModule` yields: each workspace's
    cloud is encoded once per batch), the same with ``"codes"`` (k, latent) in place of
    ``"clouds"`` (a frozen encoder's codes, computed once), with ``"grids"`` (a voxel Enet's
    occupancy, computed once: :meth:`grids`), or tuples ``(cloud (B, D), x_t, x_goal, x_next)``.
    """

    def __init__(
        self,
        pnet: Pnet | dict[str, Any],
        encoder: Enet | dict[str, Any],
        lr: float = 1e-2,
        optimizer: str = "adagrad",
        freeze_encoder: bool = True,
        *,
        state_scale: Sequence[float] | float,
        cloud_scale: Sequence[float] | float,
        val_stochastic: bool = False,
        state_offset: Sequence[float] | None = None,
        input_noise: float = 0.0,
        collision_loss: float = 0.0,
        collision_motion: int = 1,
        fused: bool = False,
    ):
        super().__init__()
        pnet = pnet if isinstance(pnet, Pnet) else Pnet(**pnet)
        encoder = encoder if isinstance(encoder, Enet) else Enet(**encoder)
        state_dim = pnet.out_dim
        if pnet.in_dim != encoder.latent + 2 * state_dim:
            raise ValueError(f"Pnet input {pnet.in_dim} != latent {encoder.latent} + 2 * state_dim {state_dim}")
        if optimizer.lower() not in OPTIMIZERS:
            raise ValueError(f"unknown optimizer {optimizer!r}; choices: {', '.join(OPTIMIZERS)}")
        self.pnet = pnet
        self.encoder = encoder
        self.state_norm = Normalizer(state_scale, state_offset)
        if self.state_norm.scale.size not in (1, state_dim):
            raise ValueError(f"state_scale has {self.state_norm.scale.size} entries, state_dim is {state_dim}")
        if pnet.bounded and self.state_norm.offset is None and state_offset is None:
            raise ValueError("a bounded Pnet needs the centred normaliser (state_offset: the bounds' centre)")
        self.cloud_norm = Normalizer(cloud_scale)
        self.freeze_encoder = bool(freeze_encoder)
        if self.freeze_encoder:
            self.encoder.requires_grad_(False)
        self.save_hyperparameters(
            {
                "pnet": pnet.config(),
                "encoder": encoder.config(),
                "lr": float(lr),
                "optimizer": optimizer.lower(),
                "freeze_encoder": self.freeze_encoder,
                "state_scale": self.state_norm.to_list(),
                "cloud_scale": self.cloud_norm.to_list(),
                "val_stochastic": bool(val_stochastic),
            }
            | ({"state_offset": [float(v) for v in state_offset]} if state_offset is not None else {})
            | ({"input_noise": float(input_noise)} if input_noise else {})
            | ({"collision_loss": float(collision_loss)} if collision_loss else {})
            | ({"collision_motion": int(collision_motion)} if collision_motion != 1 else {})
            | ({"fused": True} if fused else {})
        )
        if not 0.0 <= float(input_noise) < float("inf"):
            raise ValueError(f"input_noise must be a finite number >= 0, got {input_noise}")
        self.input_noise = float(input_noise)
        if not 0.0 <= float(collision_loss) < float("inf"):
            raise ValueError(f"collision_loss must be a finite number >= 0, got {collision_loss}")
        self.collision_loss = float(collision_loss)
        if isinstance(collision_motion, bool) or not isinstance(collision_motion, int) or collision_motion < 1:
            raise ValueError(f"collision_motion must be an integer >= 1, got {collision_motion!r}")
        self.collision_motion = int(collision_motion)
        self.clearance = None  # attach_clearance: the scenes a collision loss measures against
        self.depth = None  # the last batch's mean depth and its sample count (collision_loss)

    def attach_clearance(self, clearance) -> None:
        """The training scenes' mpnet.models.clearance.Clearance (its workspaces in the
        data's order): needed when collision_loss > 0; never saved with the networks."""
        self.clearance = clearance

    # -- inference in raw coordinates ---------------------------------------------------
    def encode(self, cloud: torch.Tensor) -> torch.Tensor:
        """Raw flattened cloud(s) -> ``Z``."""
        return self.encoder(self.cloud_norm.normalize(cloud))

    def grids(self, clouds) -> np.ndarray:
        """A voxel Enet's inputs, (n, cells) float32, of raw flattened clouds (n, D): normalised
        as encode does, then mpnet.models.voxels.occupancy, the planner's own grid."""
        if self.encoder.voxels is None:
            raise ValueError("only a voxel Enet reads a grid")
        flat = np.asarray(clouds, np.float32)
        return occupancy(self.cloud_norm.normalize(flat).astype(np.float32, copy=False), self.encoder.voxels)

    def forward(
        self, cloud: torch.Tensor, x_t: torch.Tensor, x_goal: torch.Tensor, stochastic: bool = True
    ) -> torch.Tensor:
        """Raw cloud and states -> raw next state. ``cloud`` is (D,) or (B, D)."""
        z = self.encode(cloud)
        if z.dim() < x_t.dim():
            z = z.expand(*x_t.shape[:-1], z.shape[-1])
        s = self.state_norm
        return s.denormalize(self.pnet.step(z, s.normalize(x_t), s.normalize(x_goal), stochastic))

    # -- training -----------------------------------------------------------------------
    def _unpack(self, batch):
        if isinstance(batch, dict):
            return batch.get("clouds"), batch["ws"], batch["x_t"], batch["x_goal"], batch["x_next"]
        cloud, x_t, x_goal, x_next = batch
        return cloud, None, x_t, x_goal, x_next

    def batch_loss(self, batch, stochastic: bool, noise: float = 0.0) -> tuple[torch.Tensor, int]:
        """MSE in normalised coordinates; ``noise`` (raw units, a recipe option): each x_t moved
        by N(0, noise^2) per coordinate, the target kept (DART-style: the expert's next waypoint
        from near the state, as the closed loop reaches states near the expert's). With
        ``collision_loss`` (a recipe option, MπNets'), plus that weight times the mean depth
        (metres) of the proposals' spheres in their scene's obstacles (mpnet.models.clearance;
        with ``collision_motion`` m > 1, of m states along the step to each proposal),
        measured on the batch's first COLLISION_SHARE (batches are shuffled: an unbiased
        estimate at a quarter of the cost: the depth costs about as much as the rest of a step)."""
        clouds, ws, x_t, x_goal, x_next = self._unpack(batch)
        if noise:
            x_t = x_t + noise * torch.randn_like(x_t)
        if isinstance(batch, dict) and "codes" in batch:
            if not self.freeze_encoder:
                raise ValueError("precomputed codes need a frozen encoder (freeze_encoder=True)")
            z = batch["codes"]
        elif isinstance(batch, dict) and "grids" in batch:
            with torch.set_grad_enabled(torch.is_grad_enabled() and not self.freeze_encoder):
                z = self.encoder.from_grid(batch["grids"])
        elif self.freeze_encoder:
            with torch.no_grad():
                z = self.encode(clouds)
        else:
            z = self.encode(clouds)
        if ws is not None:
            z = z[ws]
        s = self.state_norm
        pred = self.pnet.step(z, s.normalize(x_t), s.normalize(x_goal), stochastic)
        loss = F.mse_loss(pred, s.normalize(x_next))
        if self.collision_loss:
            if self.clearance is None or not isinstance(batch, dict) or "wsid" not in batch:
                raise ValueError("collision_loss needs attach_clearance and batches that name their workspaces")
            k = max(1, int(round(pred.shape[0] * COLLISION_SHARE)))
            depth = self._motion_depth(x_t[:k], s.denormalize(pred[:k]), batch["wsid"][ws[:k]])
            self.depth = (depth.detach(), k)  # the steps log it
            loss = loss + self.collision_loss * depth
        return loss, x_t.shape[0]

    def _motion_depth(self, x_t: torch.Tensor, x_new: torch.Tensor, wsid: torch.Tensor) -> torch.Tensor:
        """The mean depth of the states at 1/m, 2/m, ..., m/m of the straight motion from each
        x_t to its proposal x_new (m = collision_motion; 1: the proposal alone). NeuralPlanner
        appends a proposal without checking the step to it: steps that cross an obstacle leave
        the path infeasible, which replanning must then mend."""
        m = self.collision_motion
        if m == 1:
            return self.clearance.penetration(x_new, wsid).mean()
        t = torch.arange(1, m + 1, dtype=x_new.dtype, device=x_new.device).div(m).view(m, 1, 1)
        states = (x_t.unsqueeze(0) + t * (x_new - x_t).unsqueeze(0)).reshape(-1, x_new.shape[-1])
        return self.clearance.penetration(states, wsid.repeat(m)).mean()

    def training_step(self, batch, batch_idx: int) -> torch.Tensor:
        loss, n = self.batch_loss(batch, stochastic=True, noise=self.input_noise)
        self.log("train_loss", loss, on_step=True, on_epoch=True, prog_bar=True, batch_size=n)
        self._log_depth("train")
        return loss

    def _log_depth(self, stage: str) -> None:
        if self.collision_loss:
            depth, k = self.depth
            self.log(f"{stage}_collision_depth", depth, on_step=False, on_epoch=True, batch_size=k)

    def validation_step(self, batch, batch_idx: int) -> None:
        loss, n = self.batch_loss(batch, stochastic=self.hparams["val_stochastic"])
        self.log("val_loss", loss, on_epoch=True, prog_bar=True, batch_size=n)
        self._log_depth("val")

    def configure_optimizers(self):
        params = [p for p in self.parameters() if p.requires_grad]
        h = self.hparams
        return _make_optimizer(h["optimizer"], params, h["lr"], h.get("fused", False))


__all__ = ["EnetModule", "PnetModule", "OPTIMIZERS"]
