"""`python -m harness.sphere_audit [--env ENV] [--problems DIR] [--configurations N] [--motions M]`:
an arm's sphere checker audited against pybullet's meshes and against itself.

    python -m harness.sphere_audit --problems data/mbm/problems --configurations 1000000 --motions 100000
    python -m harness.sphere_audit --env mbm_ur5 --problems data/mbm/problems

- configurations: N random configurations spread over the scenes (MotionBenchMaker's, from
  `--problems`, else arm7's generated ones); counts those the spheres call free and pybullet
  (same fingers, margin 0) calls colliding (must be 0), and the share of pybullet-free ones
  the spheres reject (how conservative the covering is);
- motions: M random motions from valid states; each one the checker calls free is sampled
  10x finer than 0.02 rad (0.002 rad) with the sphere state check; counts the colliding ones
  (must be 0);
- queries (with `--problems`): how many of the problems' starts and goals both checkers accept,
  the spheres only (must be 0), pybullet only (valid problems the spheres refuse as
  `invalid_query`) or neither.

Exit 1 when either count is not 0.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from mpnet.envs.mbm.files import load_mbm
from mpnet.envs.specs import get_spec
from mpnet.problems import ProblemFileError


def audit(spec, scenes, configurations: int, motions: int, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    false_free = rejected = pb_free = 0
    per_ws = max(1, -(-configurations // len(scenes)))  # at least `configurations` in all
    for ws in scenes:
        qs = rng.uniform(spec.lower, spec.upper, (per_ws, spec.state_dim))
        s = spec.make_checker(ws, margin=0.0, backend="spheres").states_valid(qs)
        p = spec.make_checker(ws, margin=0.0, backend="pybullet").states_valid(qs)
        false_free += int((s & ~p).sum())
        rejected += int((p & ~s).sum())
        pb_free += int(p.sum())
    bad_motions = free_motions = 0
    per = max(1, -(-motions // len(scenes)))
    for ws in scenes:
        ch = spec.make_checker(ws, margin=0.0)
        qs = rng.uniform(spec.lower, spec.upper, (4 * per, spec.state_dim))
        ok = qs[ch.states_valid(qs)]
        if not len(ok):
            continue
        a = ok[rng.integers(0, len(ok), per)]
        b = ok[rng.integers(0, len(ok), per)]
        b = a + np.minimum(1.0, 1.0 / np.maximum(np.linalg.norm(b - a, axis=1), 1e-9))[:, None] * (b - a)
        free = ch.motions_valid(a, b)
        for x, y in zip(a[free], b[free]):
            n = int(np.ceil(np.linalg.norm(y - x) / 0.002)) + 1
            states = x + np.linspace(0, 1, n)[:, None] * (y - x)
            states[-1] = y
            bad_motions += int(not ch.states_valid(states).all())
        free_motions += int(free.sum())
    return {
        "configurations": per_ws * len(scenes),
        "false_free": false_free,
        "pybullet_free": pb_free,
        "rejected_share": rejected / max(pb_free, 1),
        "motions": per * len(scenes),
        "free_motions": free_motions,
        "free_motions_colliding": bad_motions,
    }


def query_validity(spec, testset) -> dict:
    """How many queries' start and goal both checkers accept, the spheres only, pybullet only,
    neither (each checker at margin 0)."""
    scenes = {w.id: w for w in testset.workspaces}
    out = {"both": 0, "spheres_only": 0, "pybullet_only": 0, "neither": 0}
    for q in testset.queries:
        ws, ends = scenes[q.workspace_id], np.array([q.start, q.goal])
        s = bool(spec.make_checker(ws, margin=0.0, backend="spheres").states_valid(ends).all())
        p = bool(spec.make_checker(ws, margin=0.0, backend="pybullet").states_valid(ends).all())
        out["both" if s and p else "spheres_only" if s else "pybullet_only" if p else "neither"] += 1
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.sphere_audit", description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="arm7", help="an arm env (default arm7)")
    ap.add_argument("--problems", type=Path, help="MotionBenchMaker problems (folder); default: the env's own scenes")
    ap.add_argument("--configurations", type=int, default=100_000)
    ap.add_argument("--motions", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, help="also write OUT/README.md and OUT/audit.json (e.g. reports/sphere_audit)")
    args = ap.parse_args(argv)
    try:
        spec = get_spec(args.env)
        testset = load_mbm(args.problems, spec) if args.problems else None
    except (KeyError, ValueError, ProblemFileError) as e:
        print(f"error: {e.args[0] if isinstance(e, KeyError) else e}", file=sys.stderr)
        return 2
    if testset is None and spec.generator is None:
        print(f"error: {args.env} has no scenes of its own: name --problems", file=sys.stderr)
        return 2
    scenes = testset.workspaces if testset else [spec.generator.make(i, "seen") for i in range(20)]
    t = time.perf_counter()
    r = audit(spec, scenes, args.configurations, args.motions, args.seed)
    r["env"] = args.env
    if testset is not None:
        r["queries"] = query_validity(spec, testset)
    lines = [
        f"{r['configurations']:,} configurations in {len(scenes)} scenes: {r['false_free']} called free by the "
        f"spheres and colliding by pybullet; the spheres reject {100 * r['rejected_share']:.1f}% of the "
        f"{r['pybullet_free']:,} pybullet calls free",
        f"{r['motions']:,} motions: {r['free_motions']:,} called free, {r['free_motions_colliding']} of them "
        f"colliding at 0.002 rad ({time.perf_counter() - t:.0f} s)",
    ]
    if "queries" in r:
        v = r["queries"]
        lines.append(
            f"{sum(v.values())} queries (start and goal): {v['both']} valid for both checkers, "
            f"{v['pybullet_only']} for pybullet only (the spheres call them invalid_query), "
            f"{v['spheres_only']} for the spheres only, {v['neither']} for neither"
        )
    print("\n".join(lines))
    if args.out is not None:
        print(f"written: {write_report(args.out, r, lines, argv if argv is not None else sys.argv[1:])}")
    return 1 if r["false_free"] or r["free_motions_colliding"] or r.get("queries", {}).get("spheres_only") else 0


def write_report(out: Path, result: dict, lines: list[str], argv: list[str]) -> Path:
    """OUT/README.md (where it came from, the two counts) and OUT/audit.json: the file FINDINGS
    and the docs quote the audit from."""
    from harness.core.provenance import generated_by, machine_info

    m = machine_info()
    out.mkdir(parents=True, exist_ok=True)
    (out / "audit.json").write_text(json.dumps({"machine": m, "argv": argv, **result}, indent=1))
    text = [
        f"# {result.get('env', 'arm7')}: the arm's sphere checker audited against pybullet's meshes and itself",
        "",
        generated_by(f"python -m harness.sphere_audit {' '.join(argv)}", m),
        "",
        *[f"- {line}" for line in lines],
        "",
    ]
    (out / "README.md").write_text("\n".join(text))
    return out / "README.md"


if __name__ == "__main__":
    sys.exit(main())
