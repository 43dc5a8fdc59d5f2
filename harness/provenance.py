"""Where a result came from: git revision, package versions, host, time. Written into
every run's `/run` message and every artifact's manifest."""

from __future__ import annotations

import datetime as _dt
import os
import platform
import socket
import subprocess
from importlib import metadata
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PACKAGES = ("numpy", "ompl", "python-fcl", "hydra-core", "mcap", "rerun-sdk", "torch", "lightning", "mpnet-bench")


def git_rev() -> str:
    try:
        rev = subprocess.run(
            ["git", "-C", str(REPO), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=5,
        ).stdout.strip()
        return (rev + ("-dirty" if dirty else "")) if rev else "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for pkg in PACKAGES:
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            pass
    return out


def run_info(env: str, planner: str, seed: int, split: str, config_yaml: str) -> dict:
    """The `/run` message of a bench run."""
    return {
        "env": env,
        "planner": planner,
        "seed": int(seed),
        "split": split,
        "config": config_yaml,
        "git_rev": git_rev(),
        "versions": versions(),
        "host": f"{socket.gethostname()} ({os.cpu_count()} cpus, {platform.machine()})",
        "started_at": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }


def artifact_provenance() -> dict:
    """Manifest fields of an artifact built now (git runs only when something is built): the
    revision, versions and machine, so that a build time quoted from it says where it ran."""
    m = machine_info()
    return {"git_rev": m["git_rev"], "versions": m["versions"], "machine": f"{m['cpu']} ({m['cpus']} CPUs)"}


def machine_info() -> dict:
    """The machine a measurement ran on: CPU model and count, OS, git revision, UTC time."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cpus": os.cpu_count(),
        "os": platform.platform(),
        "git_rev": git_rev(),
        "date": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "versions": versions(),
    }


def peak_rss_mb() -> float:
    """This process's peak resident memory in MB: VmHWM, which (unlike ru_maxrss) restarts
    at exec, so a spawned process does not count the pages of the parent it was forked from."""
    import resource

    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except (OSError, ValueError, IndexError):
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
