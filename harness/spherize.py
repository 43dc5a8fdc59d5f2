"""`python -m harness.spherize [MODEL]`: rebuild an arm model's sphere set (the data file
its description names, in mpnet/data_files/robots/) from the robot's collision meshes.

    python -m harness.spherize panda

The set ships with the package; this is how it was made (mpnet.envs.arm.spherize), with the
settings below recorded in the file. A changed set changes every arm cache key.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mpnet.envs.arm.model import ArmModelError, load_arm_model
from mpnet.envs.arm.spherize import spherize

SPACING = 0.0015  # m: every point of a hull lies this close to a covered sample
# Bullet tests a mesh's hull with a collision margin of about a millimetre: the pad covers
# both the sample gap and that margin (tests/mpnet/envs/checkers/test_spheres.py checks against pybullet).
PAD = 0.0025
# How far a sphere may reach beyond its link's hull (m): tighter at the wrist, hand and
# fingers, which go closest to the objects they grasp and to links 5 and 7 (a pair that is
# checked, whose hulls come within a centimetre in one configuration of ten).
TIGHT = ("panda_link5", "panda_link6", "panda_link7", "panda_hand", "panda_leftfinger", "panda_rightfinger")
REACH = dict.fromkeys(TIGHT, 0.005)
# The base stands on a table (arm7's scenes put its top 1.5 cm below the base's mesh): its
# spheres must not reach that far; it never moves, so its sphere count costs little.
REACH["panda_link0"] = 0.005
REACH_OTHERS = 0.01


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.spherize", description=__doc__.splitlines()[0])
    ap.add_argument("model", nargs="?", default="panda")
    ap.add_argument("--out", type=Path, help="write here instead of the package's data file")
    args = ap.parse_args(argv)
    try:
        model = load_arm_model(args.model)
    except ArmModelError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    reach = {m.link: REACH.get(m.link, REACH_OTHERS) for m in model.kinematics.meshes}
    doc = spherize(model, reach, SPACING, PAD)
    out = args.out or Path(__file__).resolve().parent.parent / "mpnet" / "data_files" / "robots" / model.spheres
    out.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    n = sum(len(v) for v in doc["links"].values())
    print(f"{out}: {n} spheres over {len(doc['links'])} links")
    return 0


if __name__ == "__main__":
    sys.exit(main())
