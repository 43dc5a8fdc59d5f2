"""Read the networks out of a PnetModule / EnetModule checkpoint WITHOUT importing Lightning
(importing it costs ~2 s; the bench path must not pay that).

The layout read here is the one :mod:`mpnet.models.modules` writes: ``hyper_parameters``
holds the networks' ``config()`` dicts and scales; ``state_dict`` keys are prefixed with
the module attribute (``pnet.``, ``encoder.``, ``ae.``).
"""

from __future__ import annotations

import os
import pickle
import zipfile
from dataclasses import dataclass

import torch

from mpnet.models.networks import ContractiveAE, Enet, Normalizer, NumpyEnet, NumpyPnet, Pnet, _flat_cloud


def _sub_state(state: dict, prefix: str) -> dict:
    return {k[len(prefix) :]: v for k, v in state.items() if k.startswith(prefix)}


# What torch.load raises on a damaged file (cut short: RuntimeError; empty: EOFError; garbled
# pickle: UnpicklingError; text: KeyError), besides OSError for an unreadable one.
_DAMAGED = (OSError, RuntimeError, EOFError, ValueError, KeyError, pickle.UnpicklingError, zipfile.BadZipFile)


class CheckpointError(ValueError):
    """A checkpoint file that cannot be read; `str(e)` is one line naming the file."""


def _load(path: str | os.PathLike, map_location) -> tuple[dict, dict]:
    try:
        ckpt = torch.load(path, map_location=map_location, weights_only=True)
    except _DAMAGED as e:
        detail = (str(e).strip().splitlines() or [""])[0]
        raise CheckpointError(f"{path}: unreadable checkpoint ({type(e).__name__}: {detail})") from None
    try:
        return ckpt["hyper_parameters"], ckpt["state_dict"]
    except (KeyError, TypeError) as e:
        raise CheckpointError(f"{path}: not a Lightning checkpoint of mpnet.models (missing {e})") from None


@dataclass
class PlannerNets:
    """What a planner needs: the encoder, Pnet (both in eval mode; Pnet's dropout is chosen
    per call) and the normalisers of states and clouds."""

    encoder: Enet
    pnet: Pnet
    state_norm: Normalizer
    cloud_norm: Normalizer

    def encode(self, cloud) -> torch.Tensor:
        """Raw cloud (flattened, or points (n_points, wdim)) -> ``Z`` (no autograd)."""
        with torch.inference_mode():
            c = _flat_cloud(torch.as_tensor(cloud, dtype=torch.float32), self.encoder.in_dim)
            return self.encoder(self.cloud_norm.normalize(c))

    def to_numpy(self) -> tuple[NumpyEnet, NumpyPnet]:
        """numpy versions taking RAW clouds and states (normalisers built in): exactly the
        ``encode(cloud) -> Z`` and ``step(Z, x, goal, rng) -> x_next`` callables that
        :class:`mpnet.planners.neural.MPNetPlanner` takes."""
        return NumpyEnet(self.encoder, self.cloud_norm), NumpyPnet(self.pnet, self.state_norm)


def load_pnet_checkpoint(path: str | os.PathLike, map_location="cpu") -> PlannerNets:
    hp, state = _load(path, map_location)
    if "pnet" not in hp or "encoder" not in hp:
        raise CheckpointError(f"{path}: not a PnetModule checkpoint")
    pnet, encoder = Pnet(**hp["pnet"]), Enet(**hp["encoder"])
    pnet.load_state_dict(_sub_state(state, "pnet."))
    encoder.load_state_dict(_sub_state(state, "encoder."))
    return PlannerNets(encoder.eval(), pnet.eval(), Normalizer(hp["state_scale"]), Normalizer(hp["cloud_scale"]))


def load_enet_checkpoint(path: str | os.PathLike, map_location="cpu") -> tuple[ContractiveAE, Normalizer]:
    """An EnetModule checkpoint -> (autoencoder, cloud normaliser)."""
    hp, state = _load(path, map_location)
    if "ae" not in hp:
        raise CheckpointError(f"{path}: not an EnetModule checkpoint")
    ae = ContractiveAE.from_config(hp["ae"])
    ae.lam = float(hp.get("lam", ae.lam))
    ae.load_state_dict(_sub_state(state, "ae."))
    return ae.eval(), Normalizer(hp["cloud_scale"])


__all__ = ["CheckpointError", "PlannerNets", "load_pnet_checkpoint", "load_enet_checkpoint"]
