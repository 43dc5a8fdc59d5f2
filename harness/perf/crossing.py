"""`python -m harness.perf.crossing [ENV ...] [--workspaces N] [--out DIR]`: the price of one
collision check as each kind of planner pays it, per env (also a section of `python -m
harness.perf`); the command writes DIR/crossing.md and crossing.csv. Inside
compiled code (MPNet's compiled loop, `rrt_connect_compiled`: the kernels called directly)
and through OMPL's callbacks into Python (every OMPL planner, MPNet-HR's RRT* included:
mpnet.envs.ompl_space's validity lambda and motion validator). What the crossing adds per
check, times a planner's checks, is the part of a time ratio between the two kinds that is
plumbing, not algorithm.

The same states (random, as a sampler draws them) and motions (from a random free state
toward another, cut to the env's planner range, as a tree planner extends) are checked three
ways: in a compiled loop; from Python through the checker (`is_valid`, `motion_valid`); and
through OMPL (`si.isValid`, `si.checkMotion` called from Python, less the cost of a bare
Python-to-OMPL call, which OMPL's own C++ loop does not pay). crossing = OMPL's - compiled."""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

from harness.core.threads import single_threaded

single_threaded()  # before numpy or numba load (harness.core.threads)

import numpy as np  # noqa: E402

from mpnet.envs.checkers.compiled_env import motion_free, state_free  # noqa: E402
from mpnet.envs.ompl_space import make_space_information  # noqa: E402
from mpnet.envs.specs import SPECS, generated, get_spec  # noqa: E402
from mpnet.jit import njit  # noqa: E402
from mpnet.search.rrt_connect import tree_range  # noqa: E402

STATES, MOTIONS, REPEATS = 1000, 100, 7


@njit(cache=True)
def _states_compiled(env, counts, qs):
    n = 0
    for i in range(qs.shape[0]):
        n += state_free(env, counts, qs[i])
    return n


@njit(cache=True)
def _motions_compiled(env, counts, A, B):
    n = 0
    for i in range(A.shape[0]):
        n += motion_free(env, counts, A[i], B[i])
    return n


def _per_call(run, calls: int) -> float:
    """Median over REPEATS of run()'s time per call (after one untimed run)."""
    run()
    ts = []
    for _ in range(REPEATS):
        t = time.perf_counter()
        run()
        ts.append((time.perf_counter() - t) / calls)
    return statistics.median(ts)


def range_motions(spec, rng, free: np.ndarray, n: int = MOTIONS) -> tuple[np.ndarray, np.ndarray]:
    """n motions from a free state toward another, at most the planner range long (the
    space's metric; OMPL's default range where the env sets none), as a tree planner extends."""
    reach = tree_range(spec)
    pick = rng.integers(0, len(free), size=(n, 2))
    A, B = free[pick[:, 0]], free[pick[:, 1]].copy()
    for i in range(n):
        d = spec.space.distance(A[i], B[i])
        if d > reach:
            B[i] = A[i] + spec.space.difference(A[i], B[i]) * (reach / d)
    return A, spec.space.wrap(B)


def _prices(spec, checker, rng) -> dict[str, list[float]]:
    """{check: [compiled, from Python, through OMPL] seconds per check} on one workspace."""
    kenv, counts = checker.compiled_env(), np.zeros(3, np.int64)
    qs = np.ascontiguousarray([spec.space.sample(rng) for _ in range(STATES)])
    free = qs[checker.states_valid(qs)]
    if len(free) < 2:
        raise ValueError(f"env {spec.name}: fewer than two free states among {STATES} random ones")
    A, B = (np.ascontiguousarray(x) for x in range_motions(spec, rng, free))
    si, _, set_state, keep = make_space_information(spec, checker)  # noqa: F841 (kept alive with si)
    states = [si.allocState() for _ in range(STATES)]
    for s, q in zip(states, qs):
        set_state(s, q)
    sa, sb = [si.allocState() for _ in range(MOTIONS)], [si.allocState() for _ in range(MOTIONS)]
    for s, t, a, b in zip(sa, sb, A, B):
        set_state(s, a)
        set_state(t, b)
    bare = _per_call(lambda: [si.getStateDimension() for _ in states], STATES)
    ql, al, bl = qs.tolist(), A.tolist(), B.tolist()
    prices = {
        "state": [
            _per_call(lambda: _states_compiled(kenv, counts, qs), STATES),
            _per_call(lambda: [checker.is_valid(q) for q in ql], STATES),
            _per_call(lambda: [si.isValid(s) for s in states], STATES) - bare,
        ],
        "motion": [
            _per_call(lambda: _motions_compiled(kenv, counts, A, B), MOTIONS),
            _per_call(lambda: [checker.motion_valid(a, b) for a, b in zip(al, bl)], MOTIONS),
            _per_call(lambda: [si.checkMotion(s, t) for s, t in zip(sa, sb)], MOTIONS) - bare,
        ],
    }
    return prices  # (keep, the space and validator OMPL only references, lived as long as si)


def crossing(envs: list[str], workspaces: int = 2, seed: int = 0) -> list[dict]:
    """Rows (section "crossing"): per env and kind of check, microseconds per check compiled,
    from Python, through OMPL, and the crossing (OMPL's less compiled's), medians over the
    workspaces' medians. An env whose checker has no compiled form has no row."""
    rows = []
    for env in envs:
        spec = get_spec(env)
        rng = np.random.default_rng(seed)
        checkers = [spec.make_checker(spec.generator.make(w, "seen", seed)) for w in range(workspaces)]
        per_ws = [_prices(spec, c, rng) for c in checkers if c.compiled]
        for check in ("state", "motion") if per_ws else ():
            compiled, python, ompl = (statistics.median(c) * 1e6 for c in zip(*(p[check] for p in per_ws)))
            rows.append(
                {
                    "section": "crossing",
                    "env": env,
                    "check": check,
                    "compiled_us": compiled,
                    "python_us": python,
                    "ompl_us": ompl,
                    "crossing_us": ompl - compiled,
                }
            )
    return rows


def main(argv: list[str] | None = None) -> int:
    import pandas as pd

    from harness.core.provenance import generated_by, machine_info
    from harness.perf.render import crossing_md

    ap = argparse.ArgumentParser(prog="python -m harness.perf.crossing", description=__doc__.split("\n\n")[0])
    ap.add_argument("envs", nargs="*", metavar="ENV", help=f"envs (default: all): {', '.join(SPECS)}")
    ap.add_argument("--workspaces", type=int, default=2, help="generated workspaces per env (default 2)")
    ap.add_argument("--out", type=Path, default=Path("crossing"), help="folder for crossing.md and crossing.csv")
    args = ap.parse_args(argv)
    try:
        envs = [get_spec(e).name for e in args.envs or generated()]
    except KeyError as e:
        print(f"error: {e.args[0]}", file=sys.stderr)
        return 2
    machine = machine_info()
    rows = crossing(envs, args.workspaces)
    args.out.mkdir(parents=True, exist_ok=True)
    df = pd.DataFrame(rows)
    df.to_csv(args.out / "crossing.csv", index=False)
    command = "python -m harness.perf.crossing " + " ".join([*envs, f"--workspaces {args.workspaces}"])
    head = ["# The price of a check", "", generated_by(command, machine, ", one process, nothing else running")]
    (args.out / "crossing.md").write_text("\n".join(head + crossing_md(df, None)) + "\n")
    print(f"wrote {args.out / 'crossing.md'} and crossing.csv")
    return 0


if __name__ == "__main__":
    sys.exit(main())
