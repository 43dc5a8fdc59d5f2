"""harness.core.kernels: the kernels under the run's cache_dir unless NUMBA_CACHE_DIR names a place."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # fresh interpreters

PROBE = """
import os, sys
from harness.core.kernels import use_kernel_cache
import numba
print(use_kernel_cache(sys.argv[1]), numba.config.CACHE_DIR, os.environ["NUMBA_CACHE_DIR"])
"""


def _probe(cache_dir, place=None):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    if place is not None:
        env["NUMBA_CACHE_DIR"] = str(place)
    p = subprocess.run([sys.executable, "-c", PROBE, str(cache_dir)], env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return p.stdout.split()


def test_kernels_sit_under_the_cache_dir(tmp_path):
    want = str((tmp_path / "cache" / "kernels").resolve())
    assert _probe(tmp_path / "cache") == [want] * 3  # numba (already loaded) and the processes it starts


def test_a_place_the_environment_names_wins(tmp_path):
    assert _probe(tmp_path / "cache", tmp_path / "mine") == [str(tmp_path / "mine")] * 3
