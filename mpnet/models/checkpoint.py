"""Read the networks out of a PnetModule / EnetModule checkpoint WITHOUT importing Lightning
(importing it costs ~2 s; the bench path must not pay that), and the planner's numpy networks
without importing torch either (:func:`load_pnet_numpy`: another ~1.5 s per run).

The layout read here is the one :mod:`mpnet.models.modules` writes: ``hyper_parameters``
holds the networks' ``config()`` dicts and scales; ``state_dict`` keys are prefixed with
the module attribute (``pnet.``, ``encoder.``, ``ae.``).
"""

from __future__ import annotations

import os
import pickle
import zipfile
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mpnet.models import torch_zip
from mpnet.models.numpy_nets import EnetArrays, Normalizer, NumpyEnet, NumpyPnet, PnetArrays, _flat_cloud

if TYPE_CHECKING:
    import torch

    from mpnet.models.networks import ContractiveAE, Enet, Pnet


def _sub_state(state: dict, prefix: str) -> dict:
    return {k[len(prefix) :]: v for k, v in state.items() if k.startswith(prefix)}


# What torch.load raises on a damaged file (cut short: RuntimeError; empty: EOFError; garbled
# pickle: UnpicklingError; text: KeyError), besides OSError for an unreadable one.
_DAMAGED = (OSError, RuntimeError, EOFError, ValueError, KeyError, pickle.UnpicklingError, zipfile.BadZipFile)


class CheckpointError(ValueError):
    """A checkpoint file that cannot be read; `str(e)` is one line naming the file."""


def _unreadable(path, e: BaseException) -> CheckpointError:
    detail = (str(e).strip().splitlines() or [""])[0]
    return CheckpointError(f"{path}: unreadable checkpoint ({type(e).__name__}: {detail})")


def _parts(path, ckpt) -> tuple[dict, dict]:
    try:
        return ckpt["hyper_parameters"], ckpt["state_dict"]
    except (KeyError, TypeError) as e:
        raise CheckpointError(f"{path}: not a Lightning checkpoint of mpnet.models (missing {e})") from None


def _load(path: str | os.PathLike, map_location) -> tuple[dict, dict]:
    import torch

    try:
        ckpt = torch.load(path, map_location=map_location, weights_only=True)
    except _DAMAGED as e:
        raise _unreadable(path, e) from None
    return _parts(path, ckpt)


def _load_arrays(path: str | os.PathLike) -> tuple[dict, dict]:
    """As _load, tensors as numpy arrays, without torch (mpnet.models.torch_zip)."""
    try:
        ckpt = torch_zip.load(path)
    except _DAMAGED as e:
        raise _unreadable(path, e) from None
    return _parts(path, ckpt)


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
        import torch

        with torch.inference_mode():
            c = _flat_cloud(torch.as_tensor(cloud, dtype=torch.float32), self.encoder.in_dim)
            return self.encoder(self.cloud_norm.normalize(c))

    def to_numpy(self) -> tuple[NumpyEnet, NumpyPnet]:
        """numpy versions taking RAW clouds and states (normalisers built in): exactly the
        ``encode(cloud) -> Z`` and ``step(Z, x, goal, rng) -> x_next`` callables that
        :class:`mpnet.planners.neural.MPNetPlanner` takes."""
        return NumpyEnet(self.encoder, self.cloud_norm), NumpyPnet(self.pnet, self.state_norm)


def _check_pnet(path, hp: dict) -> None:
    if "pnet" not in hp or "encoder" not in hp:
        raise CheckpointError(f"{path}: not a PnetModule checkpoint")


def load_pnet_checkpoint(path: str | os.PathLike, map_location="cpu") -> PlannerNets:
    from mpnet.models.networks import Enet, Pnet

    hp, state = _load(path, map_location)
    _check_pnet(path, hp)
    pnet, encoder = Pnet(**hp["pnet"]), Enet(**hp["encoder"])
    pnet.load_state_dict(_sub_state(state, "pnet."))
    encoder.load_state_dict(_sub_state(state, "encoder."))
    return PlannerNets(
        encoder.eval(),
        pnet.eval(),
        Normalizer(hp["state_scale"], hp.get("state_offset")),
        Normalizer(hp["cloud_scale"]),
    )


def load_pnet_numpy(path: str | os.PathLike) -> tuple[NumpyEnet, NumpyPnet]:
    """What ``load_pnet_checkpoint(path).to_numpy()`` gives, the same float32 weights, without
    importing torch: how a planning run loads its networks."""
    hp, state = _load_arrays(path)
    _check_pnet(path, hp)
    try:
        enet, pnet = (
            EnetArrays(hp["encoder"], _sub_state(state, "encoder.")),
            PnetArrays(hp["pnet"], _sub_state(state, "pnet.")),
        )
    except (KeyError, TypeError, ValueError) as e:
        raise CheckpointError(f"{path}: not a PnetModule checkpoint (weights: {type(e).__name__} {e})") from None
    return NumpyEnet(enet, Normalizer(hp["cloud_scale"])), NumpyPnet(
        pnet, Normalizer(hp["state_scale"], hp.get("state_offset"))
    )


def load_enet_checkpoint(path: str | os.PathLike, map_location="cpu") -> tuple[ContractiveAE, Normalizer]:
    """An EnetModule checkpoint -> (autoencoder, cloud normaliser)."""
    from mpnet.models.networks import ContractiveAE

    hp, state = _load(path, map_location)
    if "ae" not in hp:
        raise CheckpointError(f"{path}: not an EnetModule checkpoint")
    ae = ContractiveAE.from_config(hp["ae"])
    ae.lam = float(hp.get("lam", ae.lam))
    ae.load_state_dict(_sub_state(state, "ae."))
    return ae.eval(), Normalizer(hp["cloud_scale"])


__all__ = ["CheckpointError", "PlannerNets", "load_pnet_checkpoint", "load_pnet_numpy", "load_enet_checkpoint"]
