"""Where numba keeps the compiled kernels: under the run's artifact cache (`cache_dir/kernels`),
not beside the sources (mpnet.jit settles the place at a kernel's first use).

A `NUMBA_CACHE_DIR` the user set wins; a process this one starts inherits the place through
the variable, so a sweep's jobs and a data build's workers share one cache.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

VAR = "NUMBA_CACHE_DIR"
_USERS = os.environ.get(VAR)  # as the process found it: the user's, or a parent's choice


def use_kernel_cache(cache_dir: str | os.PathLike) -> Path:
    """Kernels under cache_dir/kernels unless the environment named a place; the place used."""
    place = Path(_USERS) if _USERS else (Path(cache_dir) / "kernels").resolve()
    os.environ[VAR] = str(place)
    if "numba" in sys.modules:  # loaded: numba read the variable as it loaded
        sys.modules["numba"].config.CACHE_DIR = str(place)
    return place
