"""A refused command leaves no run folder behind.

Hydra makes a job's folder (`outputs/<date>/<time>/`, with `.hydra/` and an empty job log)
before our code runs, so a one-line refusal (harness.core.cli.refuse) removes it again when
nothing but those start files is in it. RunDirRecord, a Hydra callback (conf/config.yaml),
notes before Hydra makes a single run's folder which of it and the folders above it are
missing: only those are removed, so a folder that existed before (a `hydra.run.dir=` the user
named) is kept (emptied of Hydra's files if it was empty). A sweep's job folder is removed
alone, never the sweep's folder nor the folders above it, which the sweep's other jobs may
be making at the same time.
"""

from __future__ import annotations

from pathlib import Path

from hydra.experimental.callback import Callback

START_FILES = ("config.yaml", "hydra.yaml", "overrides.yaml")  # what Hydra writes into .hydra/
# a single run's folder -> the folders made for it, deepest first ([] for one that was there, empty)
_made: dict[Path, list[Path]] = {}


class RunDirRecord(Callback):
    """Notes the folders that the run folder's creation will make (Hydra calls this first)."""

    def on_run_start(self, config, **kwargs) -> None:
        from omegaconf import OmegaConf
        from omegaconf.errors import OmegaConfBaseException

        try:  # resolves ${now:...} once: Hydra's job then gets the same folder (a cached resolver)
            folder = Path(str(OmegaConf.select(config, "hydra.run.dir"))).absolute()
        except OmegaConfBaseException:  # an interpolation only the job resolves: nothing noted, nothing removed
            return
        try:
            if not folder.is_dir():
                _made[folder] = [p for p in (folder, *folder.parents) if not p.exists()]
            elif not any(folder.iterdir()):
                _made[folder] = []
        except OSError:  # unreadable: Hydra says so, or the job does; nothing removed
            pass


def _start_files_only(folder: Path) -> list[Path] | None:
    """The files in `folder` if all are Hydra's start files (.hydra/'s, an empty job log);
    None when anything else is there."""
    files = []
    for p in folder.iterdir():
        if p.is_symlink():
            return None
        if p.is_dir() and p.name == ".hydra":
            inner = list(p.iterdir())
            if any(f.name not in START_FILES or f.is_symlink() or not f.is_file() for f in inner):
                return None
            files += [*inner, p]
        elif p.is_file() and p.suffix == ".log" and p.stat().st_size == 0:
            files.append(p)
        else:
            return None
    return files


def _remove(folder: Path, made: list[Path]) -> None:
    """Hydra's start files in `folder`, then the folders in `made` (`folder` and those above
    it) while they are empty; nothing when anything else is in `folder`."""
    try:
        files = _start_files_only(folder)
        if files is None:
            return
        for p in files:
            p.rmdir() if p.is_dir() else p.unlink()
        for p in made:
            p.rmdir()
    except OSError:  # something appeared meanwhile, or is not ours to remove: left as it is
        return


def discard(run_dir: Path | str | None = None) -> None:
    """Remove the folder of a refused job when nothing but Hydra's start files is in it: this
    process's Hydra job's (a single run: with the folders above it that were made for it), or
    `run_dir`, a sweep's job run in a process of its own."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    if HydraConfig.initialized():
        hydra_cfg = HydraConfig.get()
        folder = Path(hydra_cfg.runtime.output_dir).absolute()
        if hydra_cfg.mode == RunMode.RUN:
            if folder in _made:  # else it held something before, or was not noted: kept as it is
                _remove(folder, _made[folder])
            return
    elif run_dir is not None:
        folder = Path(run_dir).absolute()
    else:
        return
    _remove(folder, [folder])
