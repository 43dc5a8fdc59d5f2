"""`python -m harness.bench_checkers [ENV ...]`: collision checks per second of every
checker of each env (by backend), on generated workspaces: single states (random, as a
sampling planner draws them), and motions between random valid states, each its median and
p90 over repeats. For envs whose checker samples motions (the arm), also configurations per
second (a motion costs many).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from harness.core.threads import single_threaded

single_threaded()  # before numpy, scipy, torch or numba load (harness.core.threads)

import numpy as np  # noqa: E402

from mpnet.envs.specs import generated, get_spec  # noqa: E402

STATES, MOTIONS, REPEATS = 2000, 200, 5


def bench_checker(spec, backend: str, workspaces: int = 3, seed: int = 0, repeats: int = REPEATS) -> dict:
    """Rates of one checker: states/s and motions/s, one call each and in one vectorised
    call (median, p90 over repeats x workspaces)."""
    rng = np.random.default_rng(seed)
    state_rates, motion_rates, config_rates, batch_states, batch_motions = [], [], [], [], []
    for i in range(workspaces):
        ws = spec.generator.make(i, "seen", seed)
        ch = spec.make_checker(ws, backend=backend)
        qs = np.array([spec.space.sample(rng) for _ in range(STATES)])
        ok = ch.states_valid(qs)  # warm (the arm loads its obstacles)
        free = qs[ok]
        for _ in range(repeats):
            t = time.perf_counter()
            for q in qs.tolist():
                ch.is_valid(q)
            state_rates.append(len(qs) / (time.perf_counter() - t))
            pick = rng.integers(0, len(free), size=(MOTIONS, 2))
            a, b = free[pick[:, 0]].tolist(), free[pick[:, 1]].tolist()
            before = ch.counts().get("configurations_checked")
            t = time.perf_counter()
            for x, y in zip(a, b):
                ch.motion_valid(x, y)
            dt = time.perf_counter() - t
            motion_rates.append(MOTIONS / dt)
            if before is not None:
                config_rates.append((ch.counts()["configurations_checked"] - before) / dt)
            t = time.perf_counter()  # the same states and motions through the vectorised calls
            ch.states_valid(qs)
            batch_states.append(len(qs) / (time.perf_counter() - t))
            t = time.perf_counter()
            ch.motions_valid(free[pick[:, 0]], free[pick[:, 1]])
            batch_motions.append(MOTIONS / (time.perf_counter() - t))

    def mp(r):
        return (float(np.median(r)), float(np.percentile(r, 10))) if r else (float("nan"), float("nan"))

    out = {
        "states_per_s": mp(state_rates),
        "motions_per_s": mp(motion_rates),
        "states_per_s_batched": mp(batch_states),
        "motions_per_s_batched": mp(batch_motions),
    }
    if config_rates:
        out["configurations_per_s"] = mp(config_rates)
    return out


KEYS = ("states_per_s", "states_per_s_batched", "motions_per_s", "motions_per_s_batched")
HEAD = (
    "env     backend       states/s median (p90)   batched states/s        motions/s median (p90)   "
    "batched motions/s        configurations/s median (p90)"
)


def measure(specs, workspaces: int, repeats: int = REPEATS) -> tuple[list[dict], list[str]]:
    """One row per env x backend (its rates), and the ratio of each backend to the env's judge."""
    rows, ratios = [], []
    for spec in specs:
        rates = {}
        for backend in dict.fromkeys(spec.robot.checkers):
            r = rates[backend] = bench_checker(spec, backend, workspaces, repeats=repeats)
            rows.append({"env": spec.name, "backend": backend, **r})
        judge = spec.robot.judge_backend
        for backend, r in rates.items():
            if judge and backend != judge:
                x = [r[k][0] / rates[judge][k][0] for k in KEYS]
                ratios.append(
                    f"{spec.name} {backend} / {judge} (median rates, the same states): states {x[0]:.1f}x, "
                    f"batched states {x[1]:.1f}x, motions {x[2]:.1f}x, batched motions {x[3]:.1f}x"
                )
    return rows, ratios


def table(rows: list[dict]) -> list[str]:
    lines = [HEAD]
    for r in rows:
        cells = [f"{r[k][0]:>10,.0f} ({r[k][1]:,.0f})" for k in KEYS]
        conf = r.get("configurations_per_s")
        cells.append(f"{conf[0]:>10,.0f} ({conf[1]:,.0f})" if conf else "")
        lines.append(
            f"{r['env']:<7} {r['backend']:<13} {cells[0]:<23} {cells[1]:<23} {cells[2]:<24} {cells[3]:<24} {cells[4]}"
        )
    return lines


def write_report(out: Path, rows: list[dict], ratios: list[str], argv: list[str], repeats: int = REPEATS) -> Path:
    """OUT/README.md (where it came from, the table, the ratios) and OUT/checkers.json: the
    file FINDINGS and the docs quote checker rates from."""
    from harness.core.provenance import generated_by, machine_info

    m = machine_info()
    out.mkdir(parents=True, exist_ok=True)
    (out / "checkers.json").write_text(json.dumps({"machine": m, "rows": rows, "ratios": ratios}, indent=1))
    text = [
        "# Collision checks per second, every checker",
        "",
        generated_by(f"python -m harness.bench_checkers {' '.join(argv)}", m, ", one thread, nothing else running"),
        "",
        f"Each rate: {STATES:,} random states and {MOTIONS} motions between random valid states, on each of the "
        f"generated workspaces, {repeats} repeats; median (p90: the rate 90% of the repeats reached).",
        "",
        "```",
        *table(rows),
        "```",
        "",
        *[f"- {line}" for line in ratios],
        "",
    ]
    (out / "README.md").write_text("\n".join(text))
    return out / "README.md"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.bench_checkers", description=__doc__.splitlines()[0])
    ap.add_argument("envs", nargs="*", default=sorted(generated()))
    ap.add_argument("--workspaces", type=int, default=3)
    ap.add_argument(
        "--repeats", type=int, default=REPEATS, help=f"each rate measured this many times (default {REPEATS})"
    )
    ap.add_argument(
        "--out", type=Path, help="also write OUT/README.md and OUT/checkers.json (e.g. reports/perf/checkers)"
    )
    args = ap.parse_args(argv)
    try:
        specs = [get_spec(e) for e in args.envs]
    except KeyError as e:
        print(f"bench_checkers: {e.args[0]}", file=sys.stderr)
        return 2
    if args.workspaces < 1 or args.repeats < 1:
        print("bench_checkers: --workspaces and --repeats must be at least 1", file=sys.stderr)
        return 2
    rows, ratios = measure(specs, args.workspaces, args.repeats)
    print("\n".join(table(rows)))
    print("p90: the rate 90% of the repeats reached (the 10th percentile of rates).")
    for line in ratios:
        print(line)
    if args.out is not None:
        given = [*args.envs, *(["--workspaces", str(args.workspaces)] if args.workspaces != 3 else [])]
        given += ["--repeats", str(args.repeats)] if args.repeats != REPEATS else []
        print(f"written: {write_report(args.out, rows, ratios, given, args.repeats)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
