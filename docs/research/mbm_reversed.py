"""MotionBenchMaker's problems with every scene's objects (and each object's primitives) listed
in reverse: the same scenes, another listing (issue 42's order test).

    python docs/research/mbm_reversed.py data/mbm/problems OUT

Copies the folder to OUT and rewrites each scene file's world.collision_objects in reverse.
Then, for example:

    python -m harness +env=panda_mbm +planner=mpnet_nr problems=data/mbm/problems hydra.run.dir=RUNS/listed
    python -m harness +env=panda_mbm +planner=mpnet_nr problems=OUT hydra.run.dir=RUNS/reversed
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import yaml


def main(src: Path, out: Path) -> int:
    shutil.copytree(src, out)
    n = 0
    for path in sorted(out.rglob("scene*.yaml")):
        data = yaml.safe_load(path.read_text())
        objects = data["world"]["collision_objects"][::-1]
        for o in objects:
            for key in ("primitives", "primitive_poses"):
                if key in o:
                    o[key] = o[key][::-1]
        data["world"]["collision_objects"] = objects
        path.write_text(yaml.safe_dump(data))
        n += 1
    print(f"{n} scene files reversed into {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]), Path(sys.argv[2])))
