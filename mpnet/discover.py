"""Modules found by their file names, each registering what it holds when imported: the
robot kinds' compiled forms (mpnet.envs.checkers.compiled_env, `*_compiled.py`) and the log's
painters (harness.log.painters, `*_painter.py`). A kind of one's own is then a new file only."""

from __future__ import annotations

import importlib
import pkgutil


def import_named(package: str, suffix: str) -> None:
    """Import every module of `package` whose name ends with `suffix`."""
    for info in pkgutil.iter_modules(importlib.import_module(package).__path__):
        if info.name.endswith(suffix):
            importlib.import_module(f"{package}.{info.name}")
