"""Lightning training of MPNet's networks into artifact folders (called by
harness.artifacts.ensure.ensure_models; Lightning is imported only here).

Enet's autoencoder is an artifact of its own, so that a fit cut short during Pnet resumes
at Pnet. It keeps the random state Pnet's fit starts from, so that a resumed fit trains
the same Pnet as one run straight through. Within a fit, each epoch's end is kept too (the
artifact's partial folder, `resume`): the weights, the optimiser, the callbacks and the random
state, so that a fit cut short (Ctrl-C, a killed job, a session's end) goes on from its last
finished epoch and trains what one fit run straight through would (a test)."""

from __future__ import annotations

import os
import pickle
import random
import shutil
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from harness.core.threads import training_threads
from mpnet.data.dataset import Dataset
from mpnet.envs.scenes.generators import make_workspaces
from mpnet.envs.spec import EnvSpec

ENET_FILE, PNET_FILE, RNG_FILE = "enet.ckpt", "pnet.ckpt", "rng.npz"
LAST = "last"  # a fit's last finished epoch: <name>.last.ckpt in its partial folder


def _rng_state() -> dict:
    """The random state a fit draws from (torch's: shuffles, dropout; numpy's and Python's),
    as tensors and numbers (a checkpoint holding it still loads with weights_only)."""
    import torch

    _, keys, pos, has_gauss, gauss = np.random.get_state()
    version, internal, py_gauss = random.getstate()
    return {
        "torch": torch.get_rng_state(),
        "np_keys": torch.from_numpy(keys.astype(np.int64)),
        "np_pos": torch.tensor([pos, has_gauss]),
        "np_gauss": torch.tensor([gauss], dtype=torch.float64),
        "py": torch.tensor([version, *internal], dtype=torch.int64),
        "py_gauss": torch.tensor([np.nan if py_gauss is None else py_gauss], dtype=torch.float64),
    }


def _set_rng_state(z) -> None:
    import torch

    torch.set_rng_state(torch.as_tensor(np.asarray(z["torch"]), dtype=torch.uint8))
    pos, has_gauss = (int(v) for v in z["np_pos"])
    keys = np.asarray(z["np_keys"]).astype(np.uint32)
    np.random.set_state(("MT19937", keys, pos, has_gauss, float(z["np_gauss"][0])))
    py, gauss = [int(v) for v in z["py"]], float(z["py_gauss"][0])
    random.setstate((py[0], tuple(py[1:]), None if np.isnan(gauss) else gauss))


def _resume_state(started: float):
    """A callback that keeps in each checkpoint what Lightning's does not: the random state at
    the epoch's end, set again when a resumed fit starts training (after its sanity check,
    which draws nothing), and the seconds the fit ran before (from `started`, perf_counter)."""
    from lightning.pytorch.callbacks import Callback

    class ResumeState(Callback):
        def __init__(self):
            self.t0, self.before, self.pending, self.resumed_at = started, 0.0, None, None

        def state_dict(self) -> dict:
            return {"rng": _rng_state(), "seconds": self.seconds()}

        def load_state_dict(self, state: dict) -> None:
            self.pending, self.before = state["rng"], float(state["seconds"])

        def on_train_start(self, trainer, pl_module) -> None:
            if self.pending is not None:
                import torch

                _set_rng_state(self.pending)
                # A fit run straight through makes the next epoch's DataLoader iterator after the
                # state was kept, and the iterator draws its base seed; a resumed fit made its
                # iterator before this hook: its draw is made here (the test checks the weights).
                torch.empty((), dtype=torch.int64).random_()
                self.pending, self.resumed_at = None, trainer.current_epoch

        def seconds(self) -> float:
            return self.before + time.perf_counter() - self.t0

    return ResumeState()


def _trainer(
    folder: Path,
    name: str,
    epochs: int,
    patience: int,
    lightning: dict,
    bar,
    batches: int,
    limit_batches: int | None,
    started: float,
    keep_last: bool,
):
    """A Trainer writing into `folder`, its best epoch as <name>.ckpt; with `keep_last`, each
    finished epoch as <name>.last.ckpt too (what a resumed fit goes on from)."""
    import lightning as L
    from lightning.pytorch.callbacks import EarlyStopping, ModelCheckpoint
    from lightning.pytorch.loggers import CSVLogger

    # Enet's and Pnet's checkpoints share the artifact folder on purpose; and Lightning 2.6.6
    # calls a pytree API torch 2.13 deprecates. Neither is the user's to act on.
    warnings.filterwarnings("ignore", message=r"Checkpoint directory .* exists and is not empty")
    warnings.filterwarnings("ignore", message=r"Experiment logs directory .* exists and is not empty")
    warnings.filterwarnings("ignore", message=r".*isinstance\(treespec, LeafSpec\)")
    loggers = [CSVLogger(str(folder), name=f"{name}_logs", version=0)]
    try:
        import tensorboard  # noqa: F401  (optional: logged when installed)
        from lightning.pytorch.loggers import TensorBoardLogger

        loggers.append(TensorBoardLogger(str(folder), name=f"{name}_tb", version=0))
    except ImportError:
        pass
    checkpoint = ModelCheckpoint(
        dirpath=str(folder),
        filename=name,
        monitor="val_loss",
        mode="min",
        save_top_k=1,
        save_last=keep_last,
        enable_version_counter=False,
    )
    checkpoint.CHECKPOINT_NAME_LAST = f"{name}.{LAST}"
    resume = _resume_state(started)
    trainer = L.Trainer(
        max_epochs=epochs,
        accelerator=lightning["accelerator"],
        devices=lightning["devices"],
        strategy=lightning["strategy"],
        num_nodes=lightning.get("num_nodes", 1),
        logger=loggers,
        default_root_dir=str(folder),
        callbacks=[
            checkpoint,
            EarlyStopping("val_loss", patience=patience, mode="min"),
            resume,
            *([bar] if bar else []),
        ],
        enable_progress_bar=False,  # the stage's own bar (harness.artifacts.fit_progress) instead of Lightning's
        enable_model_summary=False,
        # every 10 steps, or each epoch's last when an epoch has fewer (Lightning warns otherwise)
        log_every_n_steps=max(1, min(10, batches, limit_batches or batches)),
        limit_train_batches=limit_batches,
        limit_val_batches=limit_batches,
    )
    return trainer, checkpoint, resume


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


def _fit(trainer, module, dm, workdir: Path, name: str) -> None:
    """trainer.fit, from the last finished epoch kept in `workdir` when there is one; Ctrl-C
    as KeyboardInterrupt: Lightning turns it into exit status 1 with its message silenced,
    which would pass for a failure."""
    last = workdir / f"{name}.{LAST}.ckpt"
    resuming = _resumable(last, module)
    if resuming:  # the CSV logger would delete the metrics of the epochs before: kept aside
        logs = workdir / f"{name}_logs" / "version_0"
        if (logs / "metrics.csv").exists():
            n = len(list(logs.glob("metrics.*.csv")))
            (logs / "metrics.csv").rename(logs / f"metrics.{n}.csv")
    try:
        trainer.fit(module, datamodule=dm, ckpt_path=str(last) if resuming else None)
    except SystemExit:
        if trainer.interrupted:
            raise KeyboardInterrupt(_kept(last, name)) from None
        raise
    except KeyboardInterrupt:
        raise KeyboardInterrupt(_kept(last, name)) from None


def _kept(last: Path, name: str) -> str:
    if not last.exists():
        return ""
    import torch

    epoch = torch.load(last, map_location="cpu", weights_only=False)["epoch"] + 1
    return f"{_TITLE.get(name, name)}'s fit is kept at epoch {epoch} in {last.parent}; the same command resumes it"


_TITLE = {"pnet": "Pnet", "enet": "Enet"}


def _resumable(last: Path, module) -> bool:
    """A kept epoch whose weights fit this module (the partial folder is the artifact's, by
    content key; a checkpoint of other shapes, e.g. from another code version, is dropped
    with a warning and the fit starts over)."""
    if not last.exists():
        return False
    import torch

    try:
        kept = torch.load(last, map_location="cpu", weights_only=False)["state_dict"]
        mine = module.state_dict()
        if kept.keys() == mine.keys() and all(kept[k].shape == mine[k].shape for k in mine):
            return True
        why = "its weights do not fit this network"
    except (OSError, RuntimeError, KeyError, EOFError, ValueError, pickle.UnpicklingError) as e:  # cut short writing it
        why = f"unreadable ({type(e).__name__})"
    print(f"warning: {last}: {why}; the fit starts over", file=sys.stderr)
    last.unlink()
    return False


def _collect(workdir: Path, folder: Path, name: str) -> None:
    """The fit's best checkpoint and logs from its partial folder into the artifact's."""
    if workdir == folder:
        return
    for item in (f"{name}.ckpt", f"{name}_logs", f"{name}_tb"):
        if (workdir / item).exists():
            shutil.move(str(workdir / item), str(folder / item))


def _bar(progress: bool, name: str, epochs: int, stage: int, stages: int, later=()):
    from harness.artifacts.fit_progress import StageBar

    return StageBar(name, epochs, stage, stages, tuple(later)) if progress else None


def _save_rng(path: Path) -> None:
    """The random state Pnet's fit starts from (torch's, numpy's, Python's)."""
    state = {k: v.numpy() for k, v in _rng_state().items()}
    np.savez(path, **{**state, "np_keys": state["np_keys"].astype(np.uint32)})  # as numpy keeps them


def _restore_rng(path: Path) -> None:
    with np.load(path) as z:
        _set_rng_state(z)


def _quiet_lightning(seed: int) -> None:
    import logging

    import lightning as L

    # Lightning's hardware banners and tips would flood the Hydra log on every fit.
    logging.getLogger("lightning.pytorch").setLevel(logging.WARNING)
    L.seed_everything(seed, workers=True, verbose=False)


@training_threads()
def fit_enet(
    spec: EnvSpec,
    data: Dataset,
    params: dict,
    lightning: dict,
    folder: Path,
    progress: bool,
    resume: Path | None = None,
) -> dict:
    """Enet as a contractive autoencoder on the training and extra layouts' clouds, into
    its own artifact folder (with the random state Pnet's fit goes on from); `resume`: where
    the fit keeps its epochs (see the module). Returns the manifest fields."""
    _quiet_lightning(params["seed"])
    flat_train = data.train_clouds.reshape(len(data.train_clouds), -1)
    fit = _fit_autoencoder(spec, data, params, lightning, folder, progress, flat_train, resume)
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
    resume: Path | None = None,
    scenes: Callable[[], list] | None = None,
) -> dict:
    """Pnet on the frozen codes of the Enet artifact `enet` (its folder and manifest), whose
    checkpoint the models folder gets a copy of; or, with `end_to_end` (the paper's arm) and
    no `enet`, Enet and Pnet together on Pnet's loss; `resume`: where the fit keeps its epochs
    (see the module); `scenes()`: the training workspaces in the data's order, for a collision
    loss (None: drawn again). Returns the manifest fields."""
    from mpnet.models import Enet

    _quiet_lightning(params["seed"])
    flat_train = data.train_clouds.reshape(len(data.train_clouds), -1)
    if enet is None:
        grid = [int(params["voxels"])] * spec.workspace_dim if params.get("voxels") else None
        encoder = Enet(flat_train.shape[1], params["enet_hidden"], params["latent"], voxels=grid)
        args = (spec, data, params, lightning, folder, progress, encoder, flat_train)
        pnet_fit = _fit_pnet(*args, False, resume, scenes)
        return {
            "files": [PNET_FILE],
            "fit": {"pnet": pnet_fit, "bytes": {PNET_FILE: (folder / PNET_FILE).stat().st_size}},
        }
    enet_folder, enet_manifest = enet
    encoder = load_encoder(enet_folder)
    _restore_rng(enet_folder / RNG_FILE)  # where a fit run straight through would be now
    _link_or_copy(enet_folder / ENET_FILE, folder / ENET_FILE)
    args = (spec, data, params, lightning, folder, progress, encoder, flat_train)
    pnet_fit = _fit_pnet(*args, True, resume, scenes)
    return {
        "files": [ENET_FILE, PNET_FILE],
        "enet_key": enet_manifest["key"],
        "fit": {
            "enet": enet_manifest["fit"],
            "pnet": pnet_fit,
            "bytes": {f: (folder / f).stat().st_size for f in (ENET_FILE, PNET_FILE)},
        },
    }


def _clearance(spec: EnvSpec, data: Dataset, scenes=None):
    """The training scenes as a collision loss measures them, in the data's order: scenes()'s
    (the cache's: harness.artifacts.ensure.training_scenes), else rebuilt from their ids and
    the data's seed."""
    from mpnet.models.clearance import Clearance

    seed = int(data.manifest["config"]["data_seed"])
    made = scenes() if scenes is not None else make_workspaces(spec, [int(i) for i in data.train_ids], "train", seed)
    arrays = spec.robot.clearance_arrays(made)
    if arrays is None:
        raise ValueError(f"env {spec.name}: its robot offers no collision loss (networks.collision_loss)")
    return Clearance(arrays, spec.planning_margin)


def _link_or_copy(src: Path, dst: Path) -> None:
    """A hard link where the file system allows one (the checkpoint is not written again)."""
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def _fit_autoencoder(spec, data, params, lightning, folder, progress, flat_train, resume=None) -> dict:
    from mpnet.models import CloudDataModule, ContractiveAE, Decoder, Enet, EnetModule

    ae_clouds = np.concatenate([data.ae_clouds.reshape(len(data.ae_clouds), -1), flat_train])
    in_dim = flat_train.shape[1]
    t0 = time.perf_counter()
    enet = Enet(in_dim, params["enet_hidden"], params["latent"])
    ae = ContractiveAE(enet, Decoder(in_dim, params["enet_hidden"], params["latent"]), params["lam"])
    scale, fused = spec.workspace_scale(), params.get("fused", False)
    ae_module = EnetModule(ae, params["lr"], optimizer=params["optimizer"], cloud_scale=scale, fused=fused)
    dm = CloudDataModule(ae_clouds, params["batch_size"], params["val_fraction"], params["seed"])
    epochs = params["ae_epochs"]
    bar = _bar(progress, "Enet", epochs, 1, 2, [("Pnet", params["pnet_epochs"])])
    work = resume or folder
    limit = params.get("limit_batches")
    trainer, ckpt, kept = _trainer(
        work, "enet", epochs, params["patience"], lightning, bar, _batches(dm), limit, t0, resume is not None
    )
    _fit(trainer, ae_module, dm, work, "enet")
    EnetModule.load_from_checkpoint(ckpt.best_model_path, map_location="cpu")  # the random draws Pnet's fit followed
    fit = {
        "seconds": kept.seconds(),
        "epochs": _epochs(trainer, work, "enet"),
        "best_val_loss": _best_score(ckpt),
        "clouds": len(ae_clouds),
        **({"resumed_at_epoch": kept.resumed_at} if kept.resumed_at is not None else {}),
    }
    _collect(work, folder, "enet")
    return fit


def _fit_pnet(
    spec, data, params, lightning, folder, progress, enet, flat_train, frozen: bool, resume=None, scenes=None
) -> dict:
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
        goals=params.get("goal_pairs") or "end",
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
        collision_loss=params.get("collision_loss", 0.0),
        collision_motion=params.get("collision_motion", 1),
        cloud_scale=spec.workspace_scale(),
        fused=params.get("fused", False),
    )
    if params.get("collision_loss"):
        module.attach_clearance(_clearance(spec, data, scenes))
    features = np.ascontiguousarray(flat_train, np.float32)
    kind = "codes" if frozen else "clouds"
    if frozen:
        with torch.no_grad():  # the encoder is frozen: each workspace's code once, not once per batch
            features = module.encode(torch.from_numpy(features)).numpy()
    elif enet.voxels is not None:  # each workspace's grid once (the clouds never change), not once per batch
        features, kind = module.grids(features), "grids"
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
        features=kind,
        scenes_per_batch=params.get("scenes_per_batch"),
    )
    bar = _bar(progress, "Pnet" if frozen else "Enet+Pnet", epochs, 2 if frozen else 1, 2 if frozen else 1)
    work = resume or folder
    limit = params.get("limit_batches")
    trainer, ckpt, kept = _trainer(
        work, "pnet", epochs, params["patience"], lightning, bar, _batches(dm), limit, t1, resume is not None
    )
    _fit(trainer, module, dm, work, "pnet")
    fit = {
        "seconds": kept.seconds(),
        "epochs": _epochs(trainer, work, "pnet"),
        "best_val_loss": _best_score(ckpt),
        "pairs": len(pairs.x_t),
        "max_epochs": epochs,
        "end_to_end": not frozen,
        **({"resumed_at_epoch": kept.resumed_at} if kept.resumed_at is not None else {}),
    }
    _collect(work, folder, "pnet")
    return fit
