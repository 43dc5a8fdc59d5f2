"""How planning cost grows with the number of obstacles: s2d-like layouts of 4, 7, 14,
28 ... random blocks (mpnet.envs.scenes.generators.RandomBlocks), written as problem files and
run through the bench like any other (`problems=FILE`). MPNet plans with the s2d networks,
trained on 7 blocks: for other counts it is out of its training distribution, and its cloud
spreads the same number of points over all the blocks."""

from __future__ import annotations

import tempfile
from pathlib import Path

from harness.perf.planners import run_one, summarize
from mpnet.data.queries import make_queries
from mpnet.envs.scenes.generators import RandomBlocks
from mpnet.envs.spec import TestSet
from mpnet.envs.specs import get_spec
from mpnet.problems import dump_problems


def layouts_file(folder: Path, blocks: int, workspaces: int, queries: int, seed: int) -> Path:
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_WARN)  # make_queries' solvability check plans with OMPL
    spec = get_spec("s2d")
    gen = RandomBlocks(blocks)
    wss = [gen.make(i, "file", seed) for i in range(workspaces)]
    qs = [q for ws in wss for q in make_queries(spec, ws, queries, seed, "file")]
    path = folder / f"s2d_blocks{blocks}.json"
    dump_problems(path, TestSet(spec, wss, qs))
    return path


def obstacles(counts: list[int], planners: list[str], common: list[str], workspaces: int, queries: int, seed: int):
    """Rows (section "obstacles") for every block count x planner, and failed runs' lines."""
    rows, errors = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for n in counts:
            f = layouts_file(Path(tmp), n, workspaces, queries, seed)
            for p in planners:
                out = run_one(["+env=s2d", f"+planner={p}", f"problems={f}", *common])
                if "error" in out:
                    errors.append(f"s2d, {n} blocks / {p}: {out['error']}")
                    continue
                row = summarize("s2d", p, out)
                row.update(section="obstacles", blocks=n)
                rows.append(row)
    return rows, errors
