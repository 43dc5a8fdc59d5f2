"""Shared fixtures: the repository's paths, the config composer, and the CLI runner."""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
KERNELS_LOCK = "MPNET_BENCH_TESTS_KERNELS_LOCK"  # held while the session's kernels compile
ARM_ENVS = ("arm7", "panda_mbm", "mbm")  # a command naming one of them waits for the arms' kernels


def pytest_configure(config):
    """The controller (not an xdist worker) compiles numba's kernels in the background
    (`python -m harness.compile_kernels`, the planar envs' first), while the workers run the
    tests: on a fresh clone, every process would otherwise compile them, an arm's for about a
    minute, each of the first ones at once. The compile holds a lock that `run_cli` waits on
    before a command on an arm (wait_for_kernels); a test planning in-process loads what is
    compiled, or compiles what is not yet (at worst what it did before)."""
    if os.environ.get("PYTEST_XDIST_WORKER") or config.option.collectonly or "not slow" in config.option.markexpr:
        return  # the fast loop's few kernels compile in its own tests sooner
    fd, lock = tempfile.mkstemp(prefix="mpnet-bench-kernels-", suffix=".lock")
    fcntl.flock(fd, fcntl.LOCK_EX)  # held by the compile's copy of fd until it exits
    config._kernels = subprocess.Popen(
        [sys.executable, "-m", "harness.compile_kernels"],
        cwd=REPO_ROOT,
        pass_fds=(fd,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(fd)
    os.environ[KERNELS_LOCK] = lock  # the workers inherit it


ARM_TESTS = ("arm", "panda", "mbm", "sphere")  # in a test's id: it plans or checks on the arm


def pytest_collection_modifyitems(config, items):
    """The slow tests first and the short ones after, to fill the workers' ends; in each, the
    arms' tests after the others, so that the background compile has their kernels on disk
    before they start (none waits, none compiles them again). pytest-xdist's worksteal
    (pyproject's addopts) hands each worker a contiguous share, then moves tests from a busy
    worker's queue to an idle one: every worker's share is dealt from this order in turn."""
    ordered = sorted(items, key=lambda i: (i.get_closest_marker("slow") is None, any(w in i.nodeid for w in ARM_TESTS)))
    n = getattr(config, "workerinput", {}).get("workercount", 1)
    items[:] = [ordered[i] for k in range(n) for i in range(k, len(ordered), n)]


def pytest_unconfigure(config):
    proc = getattr(config, "_kernels", None)
    if proc is not None:
        proc.terminate()  # a short session may end first; what is compiled stays cached
        proc.wait()
        Path(os.environ.pop(KERNELS_LOCK)).unlink(missing_ok=True)


def wait_for_kernels() -> None:
    """Until the session's background compile has finished (at once when there is none)."""
    lock = os.environ.get(KERNELS_LOCK)
    if lock and Path(lock).exists():
        fd = os.open(lock, os.O_RDONLY)
        try:
            fcntl.flock(fd, fcntl.LOCK_SH)
        finally:
            os.close(fd)


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO_ROOT


@pytest.fixture(scope="session")
def problems_dir(repo) -> Path:
    """The example problem files (valid and broken ones)."""
    return repo / "tests" / "data" / "problems"


@pytest.fixture(scope="session")
def compose_config(repo):
    """compose(overrides) -> the composed config, as `python -m harness` would see it."""
    from hydra import compose, initialize_config_dir

    def compose_(overrides: list[str], return_hydra_config: bool = False):
        with initialize_config_dir(str(repo / "conf"), version_base="1.3"):
            return compose("config", overrides, return_hydra_config=return_hydra_config)

    return compose_


@pytest.fixture(scope="session")
def settings(compose_config):
    """settings(overrides) -> the run's settings (harness.settings), as a command parses them."""
    from harness.settings import settings_of

    return lambda overrides: settings_of(compose_config(overrides))


@pytest.fixture(scope="session")
def workdir(tmp_path_factory, sweeps_cache) -> Path:
    """Where the tests' subprocesses run: a command given no run dir writes outputs/ here, never
    into the user's checkout; one given no cache_dir uses .cache/mpnet-bench here, which is the
    session's shared cache (sweeps_cache), so a tiny network trains once for the whole suite."""
    wd = tmp_path_factory.mktemp("cwd")
    sweeps_cache.mkdir(parents=True, exist_ok=True)
    (wd / ".cache").symlink_to(sweeps_cache.parent, target_is_directory=True)
    return wd


@pytest.fixture(scope="session")
def run_cli(workdir):
    """run_cli("harness", "+env=s2d", ...) runs `python -m ...` as a user does (from the
    session's workdir); raises with its output when it fails and check is true."""

    def run(*args, cwd=None, check=True, timeout=600, env=None):
        if any(e in a for a in args for e in ARM_ENVS):
            wait_for_kernels()
        env = {**os.environ, "HYDRA_FULL_ERROR": "0", **(env or {})}
        p = subprocess.run(
            [sys.executable, "-m", *args], cwd=cwd or workdir, capture_output=True, text=True, timeout=timeout, env=env
        )
        if check and p.returncode != 0:
            raise AssertionError(f"exit {p.returncode}\nstdout:\n{p.stdout}\nstderr:\n{p.stderr}")
        return p

    return run


@pytest.fixture(scope="session")
def mbm_dir(repo) -> Path:
    """Six MotionBenchMaker Panda problems (scene/request YAML pairs), test data only."""
    return repo / "tests" / "data" / "mbm"


@pytest.fixture(scope="session")
def sweeps_cache(tmp_path_factory) -> Path:
    """The session's artifact cache, shared by the suite's workers (pytest-xdist gives each
    worker its own base folder under one parent): the sweeps' cache_dir and every command's
    default one (workdir); each network trains once, the artifact store's lock making the
    others wait. A test about building artifacts gives its command a cache of its own."""
    base = tmp_path_factory.getbasetemp()
    return (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "shared-cache" / "mpnet-bench"


@pytest.fixture(scope="session")
def write_pnet_checkpoint():
    """write(path, enet, pnet, state_scale, cloud_scale): a PnetModule-layout checkpoint of
    these torch networks, as mpnet.models.checkpoint reads it."""
    return _write_pnet_checkpoint


def _write_pnet_checkpoint(path: Path, enet, pnet, state_scale: list, cloud_scale: list) -> Path:
    import torch

    state = {
        **{f"pnet.{k}": v for k, v in pnet.state_dict().items()},
        **{f"encoder.{k}": v for k, v in enet.state_dict().items()},
    }
    hp = {"pnet": pnet.config(), "encoder": enet.config(), "state_scale": state_scale, "cloud_scale": cloud_scale}
    torch.save({"hyper_parameters": hp, "state_dict": state}, path)
    return path
