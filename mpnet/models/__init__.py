"""MPNet's networks (plain torch), their LightningModules and DataModules.

Importing this package does NOT import Lightning (~2 s): the networks, the numpy export and
the checkpoint reader are loaded eagerly; the Lightning classes on first access.
"""

from __future__ import annotations

import importlib

from mpnet.models.checkpoint import CheckpointError, PlannerNets, load_enet_checkpoint, load_pnet_checkpoint
from mpnet.models.networks import (
    ENET_HIDDEN,
    ENET_LATENT,
    PNET_HIDDEN,
    ContractiveAE,
    Decoder,
    Enet,
    Normalizer,
    NumpyEnet,
    NumpyPnet,
    Pnet,
    enet_numpy,
    paper_s2d,
    pnet_numpy,
)

_LAZY = {
    "EnetModule": "mpnet.models.modules",
    "PnetModule": "mpnet.models.modules",
    "MPNetDataModule": "mpnet.models.datamodule",
    "CloudDataModule": "mpnet.models.datamodule",
    "waypoint_pairs": "mpnet.models.datamodule",
    "resample_path": "mpnet.models.datamodule",
    "split_indices": "mpnet.models.datamodule",
    "Pairs": "mpnet.models.datamodule",
}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    "PlannerNets",
    "CheckpointError",
    "load_pnet_checkpoint",
    "load_enet_checkpoint",
    *_LAZY,
]
