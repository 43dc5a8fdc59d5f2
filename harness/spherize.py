"""`python -m harness.spherize MODEL`: (re)build an arm model's sphere set (the file its
description names, beside it in its robot folder) from the robot's collision shapes.

    python -m harness.spherize panda

The Panda's set ships with the package; this is how it was made (mpnet.envs.arm.spherize), with
its settings recorded in the file: a rebuild takes them from there. A robot without a set takes
the options, else its description's `spherize:` settings, else the defaults below (a new set
goes to the user's robot folder unless the package holds one). A changed set changes every
cache key of that robot.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mpnet.envs.arm.model import ArmModelError, load_arm_model, user_robot_dir
from mpnet.envs.arm.spherize import spherize
from mpnet.envs.checkers.spheres import read_spheres

# The defaults for a robot without a sphere set yet (a rebuild takes the settings its set
# records). SPACING: every point of a hull lies this close to a covered sample. PAD: Bullet
# tests a mesh's hull with a collision margin of about a millimetre; the pad covers both the
# sample gap and that margin (tests/mpnet/envs/checkers/test_spheres.py checks against
# pybullet). REACH: how far a sphere may reach beyond its link's hull; the Panda's set has
# 5 mm at the wrist, hand and fingers (closest to what they grasp, and links 5 and 7 come
# within a centimetre) and at the base (a table top sits 1.5 cm below its mesh), 1 cm elsewhere.
SPACING, PAD, REACH = 0.0015, 0.0025, 0.01


def _reach(text: str) -> tuple[str, float]:
    link, _, metres = text.partition("=")
    return link, float(metres)


def settings(model, args, described: bool = False) -> tuple[dict[str, float], float, float]:
    """(reach per link, spacing, pad): the options given, else what the model's current sphere
    set records, else its description's `spherize:`, else the defaults; described=True: the
    description's over the set's (harness.fetch_mbm installs a robot as described)."""
    try:
        recorded = dict(model.spherize) if described else read_spheres(model)
    except (OSError, ValueError):  # a new robot: no set yet
        recorded = dict(model.spherize)
    reach = dict(recorded.get("reach", {})) | dict(args.reach)
    rest = args.reach_others if args.reach_others is not None else recorded.get("reach_others", REACH)
    links = {m.link: reach.get(m.link, rest) for m in model.kinematics.shapes}
    spacing = args.spacing if args.spacing is not None else recorded.get("spacing", SPACING)
    pad = args.pad if args.pad is not None else recorded.get("pad", PAD)
    return links, spacing, pad


def build(args: argparse.Namespace, described: bool = False) -> tuple[Path, int, int]:
    """Make the model's sphere set and write it: (file, spheres, links). ArmModelError for a
    model that cannot be read. `build(parse([MODEL]), described=True)`: its description's settings."""
    model = load_arm_model(args.model)
    reach, spacing, pad = settings(model, args, described)
    doc = spherize(model, reach, spacing, pad)
    out = args.out or model.spheres_path or user_robot_dir() / model.spheres
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    return out, sum(len(v) for v in doc["links"].values()), len(doc["links"])


def parse(argv: list[str]) -> argparse.Namespace:
    return _parser().parse_args(argv)


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m harness.spherize", description=__doc__.splitlines()[0])
    ap.add_argument("model", help="an arm model: a <model>.yaml of a robot folder (mpnet.envs.arm.model.robot_dirs)")
    ap.add_argument("--out", type=Path, help="write here instead of beside the model's description")
    ap.add_argument("--spacing", type=float, help=f"m (default: the set's recorded value, else {SPACING})")
    ap.add_argument("--pad", type=float, help=f"m (default: the set's recorded value, else {PAD})")
    reach_help = "how far a link's spheres may reach beyond its hull, m (default: the set's, else --reach-others)"
    ap.add_argument("--reach", type=_reach, action="append", default=[], metavar="LINK=M", help=reach_help)
    ap.add_argument("--reach-others", type=float, help=f"m, links without --reach or a recorded one (default {REACH})")
    return ap


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        out, n, links = build(args)
    except ArmModelError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"{out}: {n} spheres over {links} links")
    return 0


if __name__ == "__main__":
    sys.exit(main())
