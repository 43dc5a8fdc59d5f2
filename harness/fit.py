"""Lightning training of MPNet's networks into an artifact folder (called by
harness.artifacts.ensure_models; Lightning is imported only here)."""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np

from mpnet.data.dataset import Dataset
from mpnet.envs.spec import EnvSpec

ENET_FILE, PNET_FILE = "enet.ckpt", "pnet.ckpt"


def _trainer(
    folder: Path,
    name: str,
    epochs: int,
    patience: int,
    lightning: dict,
    progress: bool,
    limit_batches: int | None = None,
):
    import lightning as L
    from lightning.pytorch.callbacks import EarlyStopping, ModelCheckpoint
    from lightning.pytorch.loggers import CSVLogger

    # Enet's and Pnet's checkpoints share the artifact folder on purpose; and Lightning 2.6.6
    # calls a pytree API torch 2.13 deprecates. Neither is the user's to act on.
    warnings.filterwarnings("ignore", message=r"Checkpoint directory .* exists and is not empty")
    warnings.filterwarnings("ignore", message=r".*isinstance\(treespec, LeafSpec\)")
    loggers = [CSVLogger(str(folder), name=f"{name}_logs", version=0)]
    try:
        import tensorboard  # noqa: F401  (optional: logged when installed)
        from lightning.pytorch.loggers import TensorBoardLogger

        loggers.append(TensorBoardLogger(str(folder), name=f"{name}_tb", version=0))
    except ImportError:
        pass
    checkpoint = ModelCheckpoint(
        dirpath=str(folder), filename=name, monitor="val_loss", mode="min", save_top_k=1, enable_version_counter=False
    )
    trainer = L.Trainer(
        max_epochs=epochs,
        accelerator=lightning["accelerator"],
        devices=lightning["devices"],
        strategy=lightning["strategy"],
        num_nodes=lightning.get("num_nodes", 1),
        logger=loggers,
        default_root_dir=str(folder),
        callbacks=[checkpoint, EarlyStopping("val_loss", patience=patience, mode="min")],
        enable_progress_bar=progress,
        enable_model_summary=False,
        log_every_n_steps=10,
        limit_train_batches=limit_batches,
        limit_val_batches=limit_batches,
    )
    return trainer, checkpoint


def _best_score(ckpt) -> float:
    """The checkpoint callback's best validation loss; with strategy=ddp_spawn the fit ran
    in worker processes, which hand back the best checkpoint's path but not its score."""
    if ckpt.best_model_score is not None:
        return float(ckpt.best_model_score)
    import torch

    state = torch.load(ckpt.best_model_path, map_location="cpu", weights_only=False)["callbacks"]
    return float(next(v["best_model_score"] for k, v in state.items() if k.startswith("ModelCheckpoint")))


def _epochs(trainer, folder: Path, name: str) -> int:
    """Epochs run; after ddp_spawn's workers (the main process's trainer never ran one),
    from the CSV log they wrote."""
    if trainer.current_epoch:
        return trainer.current_epoch
    import pandas as pd

    return int(pd.read_csv(folder / f"{name}_logs" / "version_0" / "metrics.csv")["epoch"].max()) + 1


def fit_models(spec: EnvSpec, data: Dataset, params: dict, lightning: dict, folder: Path, progress: bool) -> dict:
    """Train Enet as a contractive autoencoder, then Pnet on its frozen codes; or, with
    `end_to_end` (the paper's arm), Enet and Pnet together on Pnet's loss. Returns the
    manifest fields."""
    import logging

    import lightning as L

    # Lightning's hardware banners and tips would flood the Hydra log on every fit.
    logging.getLogger("lightning.pytorch").setLevel(logging.WARNING)
    from mpnet.models import Enet

    L.seed_everything(params["seed"], workers=True, verbose=False)
    flat_train = data.train_clouds.reshape(len(data.train_clouds), -1)
    if params.get("end_to_end"):
        enet = Enet(flat_train.shape[1], params["enet_hidden"], params["latent"])
        pnet_fit = _fit_pnet(spec, data, params, lightning, folder, progress, enet, flat_train, frozen=False)
        return {
            "files": [PNET_FILE],
            "fit": {"pnet": pnet_fit, "bytes": {PNET_FILE: (folder / PNET_FILE).stat().st_size}},
        }
    enet, enet_fit = _fit_autoencoder(spec, data, params, lightning, folder, progress, flat_train)
    pnet_fit = _fit_pnet(spec, data, params, lightning, folder, progress, enet, flat_train, frozen=True)
    return {
        "files": [ENET_FILE, PNET_FILE],
        "fit": {
            "enet": enet_fit,
            "pnet": pnet_fit,
            "bytes": {f: (folder / f).stat().st_size for f in (ENET_FILE, PNET_FILE)},
        },
    }


def _fit_autoencoder(spec, data, params, lightning, folder, progress, flat_train):
    """Enet as a contractive autoencoder on the training and extra layouts' clouds."""
    from mpnet.models import CloudDataModule, ContractiveAE, Decoder, Enet, EnetModule

    ae_clouds = np.concatenate([data.ae_clouds.reshape(len(data.ae_clouds), -1), flat_train])
    in_dim = flat_train.shape[1]
    t0 = time.perf_counter()
    enet = Enet(in_dim, params["enet_hidden"], params["latent"])
    ae = ContractiveAE(enet, Decoder(in_dim, params["enet_hidden"], params["latent"]), params["lam"])
    ae_module = EnetModule(ae, lr=params["lr"], optimizer=params["optimizer"], cloud_scale=spec.workspace_scale())
    trainer, ckpt = _trainer(
        folder, "enet", params["ae_epochs"], params["patience"], lightning, progress, params.get("limit_batches")
    )
    trainer.fit(
        ae_module, datamodule=CloudDataModule(ae_clouds, params["batch_size"], params["val_fraction"], params["seed"])
    )
    ae_best = EnetModule.load_from_checkpoint(ckpt.best_model_path, map_location="cpu")
    return ae_best.encoder, {
        "seconds": time.perf_counter() - t0,
        "epochs": _epochs(trainer, folder, "enet"),
        "best_val_loss": _best_score(ckpt),
        "clouds": len(ae_clouds),
    }


def _fit_pnet(spec, data, params, lightning, folder, progress, enet, flat_train, frozen: bool) -> dict:
    """Pnet on the expert paths' waypoint pairs; Enet frozen (its codes computed once) or
    trained with it (each batch encodes the training clouds)."""
    import torch

    from mpnet.models import MPNetDataModule, Pnet, PnetModule, waypoint_pairs

    t1 = time.perf_counter()
    pairs = waypoint_pairs(data.paths.paths(), data.paths.workspace, space=spec.space)  # the planner's angles
    pnet = Pnet(params["latent"] + 2 * spec.state_dim, spec.state_dim, params["pnet_hidden"], params["dropout"])
    module = PnetModule(
        pnet,
        enet,
        lr=params["lr"],
        optimizer=params["optimizer"],
        freeze_encoder=frozen,
        state_scale=spec.space.scale(),
        cloud_scale=spec.workspace_scale(),
    )
    features = np.ascontiguousarray(flat_train, np.float32)
    if frozen:
        with torch.no_grad():  # the encoder is frozen: each workspace's code once, not once per batch
            features = module.encode(torch.from_numpy(features)).numpy()
    dm = MPNetDataModule(
        features,
        pairs.ws_index,
        pairs.x_t,
        pairs.x_goal,
        pairs.x_next,
        params["batch_size"],
        params["val_fraction"],
        params["seed"],
        groups=pairs.path_id,
        features="codes" if frozen else "clouds",
    )
    trainer, ckpt = _trainer(
        folder, "pnet", params["pnet_epochs"], params["patience"], lightning, progress, params.get("limit_batches")
    )
    trainer.fit(module, datamodule=dm)
    return {
        "seconds": time.perf_counter() - t1,
        "epochs": _epochs(trainer, folder, "pnet"),
        "best_val_loss": _best_score(ckpt),
        "pairs": len(pairs.x_t),
        "end_to_end": not frozen,
    }
