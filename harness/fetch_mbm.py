"""`python -m harness.fetch_mbm DEST`: MotionBenchMaker's Panda problems (7 scenes x 100
scene/request YAML pairs) from the `vamp-planner` source distribution on PyPI
(`resources/panda/problems.tar.bz2`, Apache-2.0), into DEST/problems/<scene>_panda/.

    python -m harness.fetch_mbm data/mbm
    python -m harness +env=arm7 +planner=rrt_connect problems=data/mbm/problems/box_panda

`--sdist FILE` uses a source distribution already downloaded. A test set: never train on it.
"""

from __future__ import annotations

import argparse
import io
import json
import sys
import tarfile
import urllib.request
from pathlib import Path

PACKAGE, VERSION = "vamp-planner", "0.6.4"
MEMBER = "resources/panda/problems.tar.bz2"


def sdist_url(version: str = VERSION) -> str:
    with urllib.request.urlopen(f"https://pypi.org/pypi/{PACKAGE}/{version}/json", timeout=60) as r:
        meta = json.load(r)
    return next(u["url"] for u in meta["urls"] if u["packagetype"] == "sdist")


def extract(sdist: bytes, dest: Path) -> list[Path]:
    """Unpack the Panda problems of a vamp-planner sdist into dest; returns the scene folders."""
    with tarfile.open(fileobj=io.BytesIO(sdist), mode="r:gz") as outer:
        member = next((m for m in outer.getmembers() if m.name.endswith(MEMBER)), None)
        if member is None:
            raise ValueError(f"the source distribution has no {MEMBER}")
        inner = outer.extractfile(member).read()
    with tarfile.open(fileobj=io.BytesIO(inner), mode="r:bz2") as problems:
        problems.extractall(dest, filter="data")
    return sorted(p.parent for p in dest.rglob("scene0001.yaml"))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.fetch_mbm", description=__doc__.splitlines()[0])
    ap.add_argument("dest", type=Path)
    ap.add_argument("--sdist", type=Path, help="a vamp-planner .tar.gz already downloaded")
    args = ap.parse_args(argv)
    try:
        data = args.sdist.read_bytes() if args.sdist else urllib.request.urlopen(sdist_url(), timeout=300).read()
        scenes = extract(data, args.dest)
    except (OSError, ValueError, tarfile.TarError, StopIteration) as e:
        print(f"fetch_mbm: {e}", file=sys.stderr)
        return 1
    for s in scenes:
        print(f"{s}: {len(list(s.glob('scene*.yaml')))} problems")
    return 0


if __name__ == "__main__":
    sys.exit(main())
