"""Issue 42, item 3: CPU seconds per panda_mbm expert path, at the revision of the code it
imports (run it with PYTHONPATH=<a checkout> to measure another revision). Builds training
scenes 0..N-1 and their expert paths in this one process, as one expert chunk does (15 MBM
queries per scene, the best of 3 RRT-Connect runs of --run-iterations iterations, contracted,
kept by env.expert.check),
after a warm-up that compiles the kernels; appends a row to reports/perf/panda_mbm_expert_rate/
README.md. Run it alone on an idle machine.

    PYTHONPATH=<checkout> python docs/research/panda_mbm_expert_rate.py [--scenes 14] [--check planner]
        [--planner rrt_connect_compiled]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ompl import util as ou

from harness.core.config import env_spec
from harness.core.provenance import git_rev, machine_info
from harness.core.settings import settings_of
from mpnet.data.expert import workspace_paths

HEADER = [
    "# panda_mbm's expert: CPU seconds per path",
    "",
    "Rows appended by `docs/research/panda_mbm_expert_rate.py`, one process, one job at a time on an otherwise "
    "idle machine: training scenes 0..N-1 drawn (scene CPU-s), then 15 MBM-style queries each, the shortest of "
    "3 RRT-Connect runs (each stopped at 2 s; from revision 76b37c1 on, at --run-iterations iterations; "
    "expert: OMPL's `rrt_connect`, or `rrt_connect_compiled`, the same recipe with each run's search compiled), "
    "contracted, kept when they pass `check` (judge: pybullet's re-check at "
    "0.002 rad; planner: the sphere checker's certified motions). Item 3's bar: 0.29 CPU-s a path "
    "(50,000 paths in 2 h on two cores).",
    "",
    "| revision | date | machine | check | expert | scenes | scene CPU-s | paths | expert CPU-s | CPU-s / path | "
    "with scenes |",
    "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenes", type=int, default=14)
    ap.add_argument("--check", default="planner", choices=["planner", "judge"])
    ap.add_argument(
        "--planner",
        default="rrt_connect",
        choices=["rrt_connect", "rrt_connect_compiled"],
        help="the expert (env.expert.planner): OMPL's RRT-Connect, or the same recipe with its search compiled",
    )
    ap.add_argument("--out", type=Path, default=Path("reports/perf/panda_mbm_expert_rate"))
    ap.add_argument(
        "--run-iterations", type=int, default=20000, help="an RRT-Connect run's budget (env.expert.run_iterations)"
    )
    args = ap.parse_args()
    ou.setLogLevel(ou.LOG_WARN)
    ou.RNG.setSeed(1)
    # the env as a build sees it: the config's planner_range (1 rad) is the expert's edge length
    # (the registry's spec has none: the earlier rows ran OMPL's default, 2.6 rad; the README says which)
    from hydra import compose, initialize_config_dir

    with initialize_config_dir(str(Path(__file__).resolve().parents[2] / "conf"), version_base="1.3"):
        cfg = compose("config", ["+env=panda_mbm"])
    spec = env_spec(cfg.env)
    assert spec.planner_range == settings_of(cfg).env.spec.planner_range == 1.0
    kw = dict(
        iterations=3,
        max_seconds=2.0,
        blocked_only=False,
        contract=True,
        planner=args.planner,
        check=args.check,
        run_iterations=args.run_iterations,
    )
    spec.generator.make(0, "train", 0)  # warm-up: IK kernels
    t0 = time.process_time()
    scenes = [spec.generator.make(i, "train", 0) for i in range(args.scenes)]
    scene_s = time.process_time() - t0
    workspace_paths(spec, scenes[0], 0, 1, 0, **kw)  # warm-up: the checker's kernels
    t0 = time.process_time()
    paths = sum(len(workspace_paths(spec, ws, i, 15, 0, **kw).workspace) for i, ws in enumerate(scenes))
    expert_s = time.process_time() - t0
    m = machine_info()
    row = (
        f"| {git_rev()[:12]} | {m.get('date', '')[:10]} | {m.get('cpu', '')} ({m.get('cpus', '')} CPUs) | "
        f"{args.check} | {args.planner} | {args.scenes} | {scene_s:.1f} | {paths} | {expert_s:.1f} | "
        f"{expert_s / paths:.3f} | {(expert_s + scene_s) / paths:.3f} |"
    )
    out = args.out / "README.md"
    args.out.mkdir(parents=True, exist_ok=True)
    lines = out.read_text().splitlines() if out.exists() else HEADER
    out.write_text("\n".join([*lines, row]) + "\n")
    print(row)


if __name__ == "__main__":
    main()
