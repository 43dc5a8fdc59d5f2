"""`python -m harness.fetch_mbm DEST [--robot MODEL ...]`: MotionBenchMaker's problems (per robot,
7 scenes x 100 scene/request YAML pairs) and the robots they are for, from the `vamp-planner`
source distribution (Apache-2.0), as `mpnet/data_files/mbm/archives.yaml` lists them: every
robot's problems into DEST/problems/<scene>_<robot>/; for each `--robot` (ur5, fetch), the URDF
and collision meshes the package cannot ship (pybullet_data has the Panda's) into the user's
robot folder (mpnet.envs.arm.model.user_robot_dir), with its sphere set made there
(harness.spherize, minutes on two cores) unless it has one made from those meshes.

The source distribution is downloaded by pip (`pip download --no-deps --no-binary
vamp-planner vamp-planner==0.6.4`), so the user's own index, mirror and proxy settings apply.
(`--no-binary :all:` would also build pip's build requirements from source, cmake among them:
many minutes.)

    python -m harness.fetch_mbm data/mbm
    python -m harness +env=arm7 +planner=rrt_connect problems=data/mbm/problems/box_panda
    python -m harness.fetch_mbm data/mbm --robot ur5
    python -m harness +env=mbm_ur5 +planner=rrt_connect problems=data/mbm/problems

`--sdist FILE` uses a source distribution already downloaded. A test set: never train on it.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import re
import subprocess
import sys
import tarfile
import tempfile
from importlib import resources
from pathlib import Path

import yaml

from harness.spherize import build, parse, settings
from mpnet.envs.arm.model import load_arm_model, user_robot_dir
from mpnet.envs.checkers.spheres import read_spheres

PACKAGE, VERSION = "vamp-planner", "0.6.4"

# what is unpacked where (data: a robot's problem sets and files are lines there)
ARCHIVES = yaml.safe_load((resources.files("mpnet") / "data_files" / "mbm" / "archives.yaml").read_text())
_VISUAL = re.compile(r"<visual\b.*?</visual>\s*", re.S)


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


def extract(sdist: bytes, dest: Path, robots: list[dict] = ()) -> list[Path]:
    """Unpack the problem archives (ARCHIVES["problems"]) of a vamp-planner sdist into dest and
    the robots given (entries of ARCHIVES["robots"]) into the user's robot folder; returns the
    scene folders."""
    with tarfile.open(fileobj=io.BytesIO(sdist), mode="r:gz") as outer:
        members = outer.getmembers()
        for archive in ARCHIVES["problems"]:
            member = next((m for m in members if m.name.endswith(archive["member"])), None)
            if member is None:
                raise ValueError(f"the source distribution has no {archive['member']}")
            inner = outer.extractfile(member).read()
            with tarfile.open(fileobj=io.BytesIO(inner), mode="r:bz2") as problems:
                problems.extractall(dest / archive["dest"], filter="data")
        for robot in robots:
            install_robot(outer, members, robot, user_robot_dir() / robot["dest"])
    return sorted(p.parent for p in dest.rglob("scene0001.yaml"))


def install_robot(sdist: tarfile.TarFile, members: list, robot: dict, to: Path) -> None:
    """A robot's URDF, without its <visual> elements, and its files (a README records what the
    URDF was), into `to`."""
    root = next((m.name.split("/")[0] for m in members if m.name.endswith(f"{robot['folder']}/{robot['urdf']}")), None)
    if root is None:
        raise ValueError(f"the source distribution has no {robot['folder']}/{robot['urdf']}")
    folder = f"{root}/{robot['folder']}/"
    wanted = [f"{folder}{f}" for f in robot["files"]]
    for m in members:
        if m.isfile() and any(m.name.startswith(w) for w in wanted):
            out = to / m.name.removeprefix(folder)
            out.parent.mkdir(parents=True, exist_ok=True)
            out.write_bytes(sdist.extractfile(m).read())
    urdf = sdist.extractfile(f"{folder}{robot['urdf']}").read()
    to.mkdir(parents=True, exist_ok=True)
    (to / robot["urdf"]).write_text(_VISUAL.sub("", urdf.decode("utf-8")), encoding="utf-8")
    (to / "README.txt").write_text(
        f"Installed by python -m harness.fetch_mbm from {root} ({PACKAGE}, Apache-2.0): {robot['folder']}/"
        f"{robot['urdf']} (sha256 {hashlib.sha256(urdf).hexdigest()}) without its <visual> elements, "
        f"and {', '.join(robot['files'])}.\n",
        encoding="utf-8",
    )


def _current(model) -> bool:
    """The model has a sphere set made from the meshes it now has (each mesh's sha256 recorded)
    with the settings its description now gives (a description that changed them remakes it)."""
    if model.spheres_path is None:
        return False
    made = read_spheres(model)
    reach, spacing, pad = settings(model, parse([model.name]), described=True)
    if (made.get("reach"), made.get("spacing"), made.get("pad")) != (reach, spacing, pad):
        return False
    return all(
        s.geometry != "mesh"
        or made["meshes"].get(s.link, {}).get("sha256") == hashlib.sha256(s.path.read_bytes()).hexdigest()
        for s in model.kinematics.shapes
    )


def make_spheres(robots: list[dict]) -> list[str]:
    """Each installed robot's sphere set, unless it has one made from these meshes (harness.spherize);
    a line each."""
    lines = []
    for robot in robots:
        model = load_arm_model(robot["model"])
        if not _current(model):
            out, n, links = build(parse([robot["model"]]), described=True)
            lines.append(f"{out}: {n} spheres over {links} links")
        else:
            lines.append(f"{model.spheres_path}: kept")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.fetch_mbm", description=__doc__.splitlines()[0])
    ap.add_argument("dest", type=Path)
    ap.add_argument("--sdist", type=Path, help="a vamp-planner .tar.gz already downloaded")
    named = [r["model"] for r in ARCHIVES["robots"]]
    ap.add_argument(
        "--robot", action="append", default=[], choices=named, help="also install this robot's files (repeatable)"
    )
    args = ap.parse_args(argv)
    robots = [r for r in ARCHIVES["robots"] if r["model"] in args.robot]
    try:
        if args.sdist:
            scenes = extract(args.sdist.read_bytes(), args.dest, robots)
        else:
            with tempfile.TemporaryDirectory() as tmp:
                scenes = extract(download_sdist(Path(tmp)).read_bytes(), args.dest, robots)
        for s in scenes:
            print(f"{s}: {len(list(s.glob('scene*.yaml')))} problems", flush=True)
        for line in make_spheres(robots):
            print(line)
    except (OSError, ValueError, tarfile.TarError, KeyError) as e:  # ArmModelError is a ValueError
        print(f"fetch_mbm: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
