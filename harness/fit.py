"""Lightning training of MPNet's networks into artifact folders (called by
harness.artifacts.ensure_models; Lightning is imported only here).

Enet's autoencoder is an artifact of its own, so that a fit cut short during Pnet resumes
at Pnet. It keeps the random state Pnet's fit starts from, so that a resumed fit trains
the same Pnet as one run straight through."""

from __future__ import annotations

import os
import random
import shutil
import time
import warnings
from pathlib import Path

import numpy as np

from harness.threads import training_threads
from mpnet.data.dataset import Dataset
from mpnet.envs.spec import EnvSpec

ENET_FILE, PNET_FILE, RNG_FILE = "enet.ckpt", "pnet.ckpt", "rng.npz"


def _trainer(
    folder: Path,
    name: str,
    epochs: int,
    patience: int,
    lightning: dict,
    bar,
    batches: int,
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
        callbacks=[checkpoint, EarlyStopping("val_loss", patience=patience, mode="min"), *([bar] if bar else [])],
        enable_progress_bar=False,  # the stage's own bar (harness.fit_progress) instead of Lightning's
        enable_model_summary=False,
        # every 10 steps, or each epoch's last when an epoch has fewer (Lightning warns otherwise)
        log_every_n_steps=max(1, min(10, batches, limit_batches or batches)),
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


def _batches(dm) -> int:
    """Training batches per epoch."""
    return -(-len(dm.train_indices) // dm.batch_size)


def _fit(trainer, module, dm) -> None:
    """trainer.fit, with Ctrl-C as KeyboardInterrupt: Lightning turns it into exit status 1
    with its message silenced, which would pass for a failure."""
    try:
        trainer.fit(module, datamodule=dm)
    except SystemExit:
        if trainer.interrupted:
            raise KeyboardInterrupt from None
        raise


def _bar(progress: bool, name: str, epochs: int, stage: int, stages: int, later=()):
    from harness.fit_progress import StageBar

    return StageBar(name, epochs, stage, stages, tuple(later)) if progress else None


def _save_rng(path: Path) -> None:
    """The random state Pnet's fit starts from (torch's, numpy's, Python's)."""
    import torch

    np_state = np.random.get_state()
    version, internal, gauss = random.getstate()
    np.savez(
        path,
        torch=torch.get_rng_state().numpy(),
        np_keys=np_state[1],
        np_pos=np.array([np_state[2], np_state[3]]),
        np_gauss=np.array([np_state[4]]),
        py=np.array([version, *internal], np.int64),
        py_gauss=np.array([np.nan if gauss is None else gauss]),
    )


def _restore_rng(path: Path) -> None:
    import torch

    with np.load(path) as z:
        torch.set_rng_state(torch.from_numpy(z["torch"].copy()))
        pos, has_gauss = (int(v) for v in z["np_pos"])
        np.random.set_state(("MT19937", z["np_keys"], pos, has_gauss, float(z["np_gauss"][0])))
        py, gauss = [int(v) for v in z["py"]], float(z["py_gauss"][0])
        random.setstate((py[0], tuple(py[1:]), None if np.isnan(gauss) else gauss))


def _quiet_lightning(seed: int) -> None:
    import logging

    import lightning as L

    # Lightning's hardware banners and tips would flood the Hydra log on every fit.
    logging.getLogger("lightning.pytorch").setLevel(logging.WARNING)
    L.seed_everything(seed, workers=True, verbose=False)


@training_threads()
def fit_enet(spec: EnvSpec, data: Dataset, params: dict, lightning: dict, folder: Path, progress: bool) -> dict:
    """Enet as a contractive autoencoder on the training and extra layouts' clouds, into
    its own artifact folder (with the random state Pnet's fit goes on from). Returns the
    manifest fields."""
    _quiet_lightning(params["seed"])
    flat_train = data.train_clouds.reshape(len(data.train_clouds), -1)
    fit = _fit_autoencoder(spec, data, params, lightning, folder, progress, flat_train)
    _save_rng(folder / RNG_FILE)
    return {"files": [ENET_FILE, RNG_FILE], "fit": fit}


def load_encoder(enet_folder: Path):
    """The trained encoder of an Enet artifact."""
    from mpnet.models import EnetModule

    return EnetModule.load_from_checkpoint(enet_folder / ENET_FILE, map_location="cpu").encoder


@training_threads()
def fit_models(
    spec: EnvSpec,
    data: Dataset,
    params: dict,
    lightning: dict,
    folder: Path,
    progress: bool,
    enet: tuple[Path, dict] | None = None,
) -> dict:
    """Pnet on the frozen codes of the Enet artifact `enet` (its folder and manifest), whose
    checkpoint the models folder gets a copy of; or, with `end_to_end` (the paper's arm) and
    no `enet`, Enet and Pnet together on Pnet's loss. Returns the manifest fields."""
    from mpnet.models import Enet

    _quiet_lightning(params["seed"])
    flat_train = data.train_clouds.reshape(len(data.train_clouds), -1)
    if enet is None:
        encoder = Enet(flat_train.shape[1], params["enet_hidden"], params["latent"])
        pnet_fit = _fit_pnet(spec, data, params, lightning, folder, progress, encoder, flat_train, frozen=False)
        return {
            "files": [PNET_FILE],
            "fit": {"pnet": pnet_fit, "bytes": {PNET_FILE: (folder / PNET_FILE).stat().st_size}},
        }
    enet_folder, enet_manifest = enet
    encoder = load_encoder(enet_folder)
    _restore_rng(enet_folder / RNG_FILE)  # where a fit run straight through would be now
    _link_or_copy(enet_folder / ENET_FILE, folder / ENET_FILE)
    pnet_fit = _fit_pnet(spec, data, params, lightning, folder, progress, encoder, flat_train, frozen=True)
    return {
        "files": [ENET_FILE, PNET_FILE],
        "enet_key": enet_manifest["key"],
        "fit": {
            "enet": enet_manifest["fit"],
            "pnet": pnet_fit,
            "bytes": {f: (folder / f).stat().st_size for f in (ENET_FILE, PNET_FILE)},
        },
    }


def _link_or_copy(src: Path, dst: Path) -> None:
    """A hard link where the file system allows one (the checkpoint is not written again)."""
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def _fit_autoencoder(spec, data, params, lightning, folder, progress, flat_train) -> dict:
    from mpnet.models import CloudDataModule, ContractiveAE, Decoder, Enet, EnetModule

    ae_clouds = np.concatenate([data.ae_clouds.reshape(len(data.ae_clouds), -1), flat_train])
    in_dim = flat_train.shape[1]
    t0 = time.perf_counter()
    enet = Enet(in_dim, params["enet_hidden"], params["latent"])
    ae = ContractiveAE(enet, Decoder(in_dim, params["enet_hidden"], params["latent"]), params["lam"])
    ae_module = EnetModule(ae, lr=params["lr"], optimizer=params["optimizer"], cloud_scale=spec.workspace_scale())
    dm = CloudDataModule(ae_clouds, params["batch_size"], params["val_fraction"], params["seed"])
    epochs = params["ae_epochs"]
    bar = _bar(progress, "Enet", epochs, 1, 2, [("Pnet", params["pnet_epochs"])])
    trainer, ckpt = _trainer(
        folder, "enet", epochs, params["patience"], lightning, bar, _batches(dm), params.get("limit_batches")
    )
    _fit(trainer, ae_module, dm)
    EnetModule.load_from_checkpoint(ckpt.best_model_path, map_location="cpu")  # the random draws Pnet's fit followed
    return {
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
    from mpnet.models.numpy_nets import Normalizer

    t1 = time.perf_counter()
    pairs = waypoint_pairs(  # the planner's angles
        data.paths.paths(),
        data.paths.workspace,
        bidirectional=params.get("bidirectional", True),
        space=spec.space,
        waypoint_step=params.get("waypoint_step"),
        min_waypoints=params.get("min_waypoints"),
    )
    epochs = params["pnet_epochs"]
    if params.get("equal_steps"):  # as many gradient steps as the scale's networks take on the plain pairs
        plain = sum(2 * (len(p) - 1) for p in data.paths.paths() if len(p) >= 2)  # waypoint_pairs' count
        epochs = max(1, round(epochs * plain / len(pairs.x_t)))
    bounded = bool(params.get("bounded"))
    pnet = Pnet(
        params["latent"] + 2 * spec.state_dim, spec.state_dim, params["pnet_hidden"], params["dropout"], bounded
    )
    # a bounded Pnet's (-1, 1) is the bounds exactly: the centred normaliser
    norm = Normalizer.centred(spec.space.bounds) if bounded else Normalizer(spec.space.scale())
    module = PnetModule(
        pnet,
        enet,
        lr=params["lr"],
        optimizer=params["optimizer"],
        freeze_encoder=frozen,
        state_scale=norm.to_list(),
        # the centre, zeros included (symmetric bounds: the normaliser keeps no offset, the module must know)
        state_offset=(norm.offset_list() or [0.0] * spec.state_dim) if bounded else None,
        input_noise=params.get("input_noise", 0.0),
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
    bar = _bar(progress, "Pnet" if frozen else "Enet+Pnet", epochs, 2 if frozen else 1, 2 if frozen else 1)
    trainer, ckpt = _trainer(
        folder, "pnet", epochs, params["patience"], lightning, bar, _batches(dm), params.get("limit_batches")
    )
    _fit(trainer, module, dm)
    return {
        "seconds": time.perf_counter() - t1,
        "epochs": _epochs(trainer, folder, "pnet"),
        "best_val_loss": _best_score(ckpt),
        "pairs": len(pairs.x_t),
        "max_epochs": epochs,
        "end_to_end": not frozen,
    }
