"""`python -m harness.spherize [MODEL]`: rebuild an arm model's sphere set (the data file
its description names, in mpnet/data_files/robots/) from the robot's collision meshes.

    python -m harness.spherize panda

The set ships with the package; this is how it was made (mpnet.envs.arm.spherize), with its
settings recorded in the file: a rebuild takes them from there (a new robot: the options, or
the defaults below). A changed set changes every arm cache key.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mpnet.envs.arm.model import ArmModelError, load_arm_model
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


def settings(model, args) -> tuple[dict[str, float], float, float]:
    """(reach per link, spacing, pad): the options given, else what the model's current
    sphere set records, else the defaults."""
    try:
        recorded = read_spheres(model)
    except (OSError, ValueError):  # a new robot: no set yet
        recorded = {}
    reach = dict(recorded.get("reach", {})) | dict(args.reach)
    others = REACH if args.reach_others is None else args.reach_others
    links = {m.link: reach.get(m.link, others) for m in model.kinematics.meshes}
    spacing = args.spacing if args.spacing is not None else recorded.get("spacing", SPACING)
    pad = args.pad if args.pad is not None else recorded.get("pad", PAD)
    return links, spacing, pad


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.spherize", description=__doc__.splitlines()[0])
    ap.add_argument("model", help="an arm model of mpnet/data_files/robots (its <model>.yaml)")
    ap.add_argument("--out", type=Path, help="write here instead of the package's data file")
    ap.add_argument("--spacing", type=float, help=f"m (default: the set's recorded value, else {SPACING})")
    ap.add_argument("--pad", type=float, help=f"m (default: the set's recorded value, else {PAD})")
    reach_help = "how far a link's spheres may reach beyond its hull, m (default: the set's, else --reach-others)"
    ap.add_argument("--reach", type=_reach, action="append", default=[], metavar="LINK=M", help=reach_help)
    ap.add_argument("--reach-others", type=float, help=f"m, links without --reach or a recorded one (default {REACH})")
    args = ap.parse_args(argv)
    try:
        model = load_arm_model(args.model)
    except ArmModelError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    reach, spacing, pad = settings(model, args)
    doc = spherize(model, reach, spacing, pad)
    out = args.out or Path(__file__).resolve().parent.parent / "mpnet" / "data_files" / "robots" / model.spheres
    out.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    n = sum(len(v) for v in doc["links"].values())
    print(f"{out}: {n} spheres over {len(doc['links'])} links")
    return 0


if __name__ == "__main__":
    sys.exit(main())
