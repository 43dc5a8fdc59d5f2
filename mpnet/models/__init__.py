"""MPNet's networks (plain torch), their LightningModules and DataModules.

Importing this package imports nothing heavy: each name loads its module on first access, so
a planning run that reads its networks with numpy (``load_pnet_numpy``) never imports torch
(~1.5 s), and nothing here imports Lightning (~2 s) until a LightningModule is asked for.
"""

from __future__ import annotations

import importlib

_NETWORKS = ("ENET_HIDDEN", "ENET_LATENT", "PNET_HIDDEN", "ContractiveAE", "Decoder", "Enet", "Pnet")
_NETWORKS += ("enet_numpy", "paper_s2d", "pnet_numpy")
_LAZY = {
    **dict.fromkeys(_NETWORKS, "mpnet.models.networks"),
    **dict.fromkeys(("Normalizer", "NumpyEnet", "NumpyPnet"), "mpnet.models.numpy_nets"),
    **dict.fromkeys(
        ("CheckpointError", "PlannerNets", "load_enet_checkpoint", "load_pnet_checkpoint", "load_pnet_numpy"),
        "mpnet.models.checkpoint",
    ),
    "EnetModule": "mpnet.models.modules",
    "PnetModule": "mpnet.models.modules",
    "MPNetDataModule": "mpnet.models.datamodule",
    "CloudDataModule": "mpnet.models.datamodule",
    "waypoint_pairs": "mpnet.models.pairs",
    "resample_path": "mpnet.models.pairs",
    "split_indices": "mpnet.models.pairs",
    "Pairs": "mpnet.models.pairs",
}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = list(_LAZY)
