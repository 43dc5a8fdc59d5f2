"""Shared fixtures (the repository's paths, the config composer, the CLI runner) and the
session's set-up: numba's kernels compiled in the background, the tests' order."""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
KERNELS_LOCK = "MPNET_BENCH_TESTS_KERNELS_LOCK"  # held while the arms' kernels compile
PLANAR_LOCK = "MPNET_BENCH_TESTS_PLANAR_LOCK"  # held while the planar envs' kernels compile (every test waits)
KERNELS_WAIT_S = 900  # a test waits no longer for them: past it, it compiles what it needs itself
ARM_ENVS = ("arm7", "panda_mbm")  # a command naming one of them waits for the arms' kernels
# in a test's id, its folders aside (uses_arm): it uses the arm's kernels
ARM_TESTS = ("arm7", "test_arm", "panda", "mbm", "sphere", "checkers", "clearance", "robot_files")
# numba's kernels: one cache for the session, its workers and every command they start (whatever
# cache_dir a test gives), unless the environment names one; in the user's cache, not the
# checkout (the tests write only into temporary folders), kept between sessions (warm loops)
_USER_CACHE = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
os.environ.setdefault("NUMBA_CACHE_DIR", str(_USER_CACHE / "mpnet-bench" / "test-kernels"))
# Robots installed by harness.fetch_mbm (the UR5's, the Fetch's) are not the suite's: its robot folder
# is an empty one (a test that installs a robot gives its own), so a run here and on CI see the same envs
os.environ["MPNET_BENCH_ROBOTS"] = str(_USER_CACHE / "mpnet-bench" / "test-robots")
# Where bytecode may not be written (PYTHONDONTWRITEBYTECODE), pytest rewrote every test module's
# asserts afresh in every worker of every run (~3.7 s a worker, half a warm worker's collection):
# the suite's processes keep Python's bytecode, in the __pycache__ folders git ignores (a prefix
# elsewhere, sys.pycache_prefix, would also recompile every installed package once, ~7 s a process)
sys.dont_write_bytecode = False


def pytest_configure(config):
    """The controller (not an xdist worker) compiles numba's kernels in the background
    (`python -m harness.compile_kernels`) while the workers run the tests: on a fresh clone, every
    process would otherwise compile them, an arm's for about a minute, each of the first ones at
    once. Two compiles at once, each holding a lock until its kernels are on disk: the planar
    envs' (~40 s; every test waits for it: the first tests had compiled them again beside it)
    and the arms' (which `run_cli` waits on before a command on an arm: wait_for_kernels; a
    test planning in-process on an arm loads what is compiled, or compiles what is not yet).
    Side by side, not one after the other: while every test waits for the planar kernels, the
    arms' compile has the other core (it had idled for those ~40 s)."""
    if config.pluginmanager.hasplugin("xdist"):
        config.pluginmanager.register(WorkSteal(), "mpnet-bench-worksteal")
    if os.environ.get("PYTEST_XDIST_WORKER") or config.option.collectonly or "not slow" in config.option.markexpr:
        return  # the fast loop's few kernels compile in its own tests sooner
    config._kernels = []
    for env_var, prefix, arms in ((PLANAR_LOCK, "planar", False), (KERNELS_LOCK, "kernels", True)):
        fd, lock = tempfile.mkstemp(prefix=f"mpnet-bench-{prefix}-", suffix=".lock")
        fcntl.flock(fd, fcntl.LOCK_EX)  # held by the compile's copy of fd until it exits
        log = Path(lock).with_suffix(".log")
        with log.open("w") as out:
            proc = subprocess.Popen(
                [sys.executable, "-c", COMPILE, ",".join(ARM_ENVS), str(arms)],
                cwd=REPO_ROOT,
                pass_fds=(fd,),
                stdout=out,
                stderr=out,
            )
        os.close(fd)
        config._kernels.append((proc, log))
        os.environ[env_var] = lock  # the workers inherit them


# harness.compile_kernels for the planar envs (argv[2] False) or the arms (argv[1]: their names)
COMPILE = """import sys
from harness.compile_kernels import main
from mpnet.envs.specs import generated
arms, want = sys.argv[1].split(","), sys.argv[2] == "True"
sys.exit(main([e for e in generated() if (e in arms) == want]))
"""


def pytest_unconfigure(config):
    """The background compiles stopped if the session ended first (what they compiled stays
    cached), and said if one failed."""
    if not hasattr(config, "_kernels"):
        return
    for proc, log in config._kernels:
        failed = proc.poll() not in (None, 0)
        proc.terminate()
        proc.wait()
        if failed:
            text = f"harness.compile_kernels failed (exit {proc.returncode}): {log.read_text()[-2000:]}"
            reporter = config.pluginmanager.get_plugin("terminalreporter")
            if reporter is not None:
                reporter.write_line(text, red=True)
            else:
                print(text, file=sys.stderr)
        log.unlink(missing_ok=True)
    Path(os.environ.pop(KERNELS_LOCK)).unlink(missing_ok=True)
    Path(os.environ.pop(PLANAR_LOCK)).unlink(missing_ok=True)


def wait_for_kernels(timeout_s: float = KERNELS_WAIT_S, which: str = KERNELS_LOCK) -> None:
    """Until the session's background compile of the arms' kernels has finished (at once when there
    is none), or timeout_s; which=PLANAR_LOCK: the planar envs' kernels."""
    lock = os.environ.get(which)
    if not lock or not Path(lock).exists():
        return
    fd, deadline = os.open(lock, os.O_RDONLY), time.monotonic() + timeout_s
    try:
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
                return
            except BlockingIOError:
                if time.monotonic() > deadline:
                    return
                time.sleep(0.5)
    finally:
        os.close(fd)


class WorkSteal:
    """pytest-xdist's worksteal in place of its default (`load`): an idle worker takes tests
    from a busy one's queue (with `load`, one worker ended a run with ~100 queued tests while
    the other idled). Another --dist given is kept. A plugin registered only where xdist is
    (pytest refuses a conftest hook it has no spec for: `-p no:xdist`)."""

    @staticmethod
    def pytest_xdist_make_scheduler(config, log):
        if config.getoption("dist") != "load":
            return None
        from xdist.scheduler import WorkStealingScheduling

        return WorkStealingScheduling(config, log)


def deal(ordered: list, n: int) -> list:
    """`ordered` rearranged so that worksteal's first hand-out, contiguous shares of
    len // n, len // (n - 1) of the rest, ... (xdist's WorkStealingScheduling.check_schedule),
    gives each of the n workers every n-th test, each in this order."""
    r = len(ordered) % n
    shares = [[] for _ in range(n)]
    for i, item in enumerate(ordered):
        shares[(i + n - r) % n].append(item)  # the last r shares are one longer
    return [item for share in shares for item in share]


def pytest_collection_modifyitems(config, items):
    """The slow tests first and the short ones after, to fill the workers' ends; in each, the
    arms' tests after the others, so that the background compile has their kernels on disk
    before they start (none waits, none compiles them again); dealt to the workers (deal)."""
    ordered = sorted(items, key=lambda i: (i.get_closest_marker("slow") is None, uses_arm(i.nodeid)))
    items[:] = deal(ordered, getattr(config, "workerinput", {}).get("workercount", 1))


def uses_arm(nodeid: str) -> bool:
    """Whether a test uses the arm's kernels, by ARM_TESTS in its id from its file's name on
    (tests/mpnet/envs/checkers/ holds the planar robots' checkers' tests too)."""
    path, sep, rest = nodeid.partition("::")
    return any(w in path.rsplit("/", 1)[-1] + sep + rest for w in ARM_TESTS)


@pytest.fixture(autouse=True)
def _planar_kernels():
    """Every test starts once the planar envs' kernels are on disk (the session's first ~40 s):
    the first tests had compiled them again beside the background compile."""
    wait_for_kernels(which=PLANAR_LOCK)


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
    """settings(overrides) -> the run's settings (harness.core.settings), as a command parses them."""
    from harness.core.settings import settings_of

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
        if any(e in a for a in args for e in ARM_ENVS):  # the planar ones: every test waited (_planar_kernels)
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
