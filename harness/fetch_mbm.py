"""`python -m harness.fetch_mbm DEST`: MotionBenchMaker's problems (per robot, 7 scenes x 100
scene/request YAML pairs) from the `vamp-planner` source distribution (Apache-2.0): the archives
`mpnet/data_files/mbm/archives.yaml` lists (the Panda's `resources/panda/problems.tar.bz2`, into
DEST/problems/<scene>_panda/).

The source distribution is downloaded by pip (`pip download --no-deps --no-binary
vamp-planner vamp-planner==0.6.4`), so the user's own index, mirror and proxy settings apply.
(`--no-binary :all:` would also build pip's build requirements from source, cmake among them:
many minutes.)

    python -m harness.fetch_mbm data/mbm
    python -m harness +env=arm7 +planner=rrt_connect problems=data/mbm/problems/box_panda

`--sdist FILE` uses a source distribution already downloaded. A test set: never train on it.
"""

from __future__ import annotations

import argparse
import io
import subprocess
import sys
import tarfile
import tempfile
from importlib import resources
from pathlib import Path

import yaml

PACKAGE, VERSION = "vamp-planner", "0.6.4"
# the archives unpacked, each into DEST/<dest> (data: a robot's problem sets are a line there)
ARCHIVES = yaml.safe_load((resources.files("mpnet") / "data_files" / "mbm" / "archives.yaml").read_text())


def download_sdist(folder: Path, version: str = VERSION) -> Path:
    """The vamp-planner source distribution, downloaded into folder by pip (the user's
    configured index); OSError with pip's last line when it fails."""
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--no-binary", PACKAGE, "-d", str(folder)]
    p = subprocess.run([*cmd, f"{PACKAGE}=={version}"], capture_output=True, text=True)
    found = sorted(folder.glob("vamp_planner-*.tar.gz")) + sorted(folder.glob("vamp-planner-*.tar.gz"))
    if p.returncode != 0 or not found:
        last = (p.stderr.strip() or p.stdout.strip() or "no file").splitlines()[-1]
        raise OSError(f"pip download {PACKAGE}=={version} failed: {last}")
    return found[0]


def extract(sdist: bytes, dest: Path) -> list[Path]:
    """Unpack the problem archives (ARCHIVES) of a vamp-planner sdist into dest; returns the scene folders."""
    with tarfile.open(fileobj=io.BytesIO(sdist), mode="r:gz") as outer:
        members = outer.getmembers()
        for archive in ARCHIVES:
            member = next((m for m in members if m.name.endswith(archive["member"])), None)
            if member is None:
                raise ValueError(f"the source distribution has no {archive['member']}")
            inner = outer.extractfile(member).read()
            with tarfile.open(fileobj=io.BytesIO(inner), mode="r:bz2") as problems:
                problems.extractall(dest / archive["dest"], filter="data")
    return sorted(p.parent for p in dest.rglob("scene0001.yaml"))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.fetch_mbm", description=__doc__.splitlines()[0])
    ap.add_argument("dest", type=Path)
    ap.add_argument("--sdist", type=Path, help="a vamp-planner .tar.gz already downloaded")
    args = ap.parse_args(argv)
    try:
        if args.sdist:
            scenes = extract(args.sdist.read_bytes(), args.dest)
        else:
            with tempfile.TemporaryDirectory() as tmp:
                scenes = extract(download_sdist(Path(tmp)).read_bytes(), args.dest)
    except (OSError, ValueError, tarfile.TarError, StopIteration) as e:
        print(f"fetch_mbm: {e}", file=sys.stderr)
        return 1
    for s in scenes:
        print(f"{s}: {len(list(s.glob('scene*.yaml')))} problems")
    return 0


if __name__ == "__main__":
    sys.exit(main())
