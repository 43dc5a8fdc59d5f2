"""`python -m harness.recheck PATH... [--step S] [--jobs N]`: every success a run logged, re-checked
from its trials.mcap alone, in a fresh process with a fresh collision world.

The workspace of each query is rebuilt from the logged `/workspace` obstacles (posed
primitives included), and the logged joint path is sampled at `--step` (default: half the
env's validation step, so finer than the bench's own judge) against a checker of the env
with no margin, the robot model the log names. This is the arm's re-check (pybullet, a new
DIRECT client, the arm model of the log: logs from before arm models were data re-check with
pybullet_data's Panda as it was then), and the env's own checkers for the 2D/3D and rigid
envs. Exit 1 on any false success or unreadable file. `--jobs N` re-checks N files at once, each
in its own process (a sweep's files are independent), and a file's successes in several processes
when there are fewer files than that; what it prints and writes is the same.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.log.mcap_io import read_log
from harness.report.readme import RECHECK_FILE
from mpnet.envs.specs import get_spec
from mpnet.envs.workspace import Workspace
from mpnet.motion import verify_path
from mpnet.workers import process_pool


def recheck_file(path: Path, step: float | None = None) -> tuple[int, list[tuple[str, str]], float]:
    """(successes re-checked, [(query id, why)] of the false ones, step used) of one log."""
    n, false, step = _recheck_share(path, step)
    return n, [(qid, why) for _, qid, why in false], step


def _recheck_share(
    path: Path, step: float | None = None, share: tuple[int, int] = (0, 1)
) -> tuple[int, list[tuple[int, str, str]], float]:
    """recheck_file of successes i, i + n, i + 2n, ... of the log (share (i, n): a file re-checked
    by n processes), each false one with its success's place in the log."""
    msgs, _ = read_log(path, ("/run", "/workspace", "/query"))
    run = next((m.data for m in msgs if m.topic == "/run"), None)
    if run is None:
        raise ValueError("no /run message")
    spec = get_spec(run["env"])
    step = step or spec.validation_step / 2
    workspaces = {(m.data["split"], m.data["workspace_id"]): m.data for m in msgs if m.topic == "/workspace"}
    built: dict[tuple, Workspace] = {}
    n, false, seen = 0, [], -1
    for m in msgs:
        q = m.data
        if m.topic != "/query" or not q.get("success"):
            continue
        seen += 1
        if seen % share[1] != share[0]:
            continue
        key = (q["split"], q["workspace_id"])
        if key not in built:
            w = workspaces.get(key)
            if w is None:
                false.append((seen, q["query_id"], "no /workspace message for it"))
                continue
            built[key] = (
                Workspace.from_json(w["workspace_id"], w["split"], w["obstacles"], spec.workspace_dim),
                spec.for_logged_robot(w.get("robot")),
            )
        ws, logged = built[key]
        why = verify_path(logged, ws, q["path"], q["start"], q["goal"], step)
        n += 1
        if why is not None:
            false.append((seen, q["query_id"], why))
    return n, false, step


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.recheck", description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="+", metavar="PATH", help="trials.mcap files or folders searched for them")
    ap.add_argument("--step", type=float, default=None, help="sampling step (default: half the env's validation step)")
    ap.add_argument("--out", type=Path, help="also write OUT/recheck.md (a report folder: its successes, verified)")
    ap.add_argument(
        "--jobs", type=int, default=1, help="processes: files at once, or a file's successes shared (default 1)"
    )
    args = ap.parse_args(argv)
    if args.step is not None and not args.step > 0:
        print(f"error: --step must be a positive number, got {args.step}", file=sys.stderr)
        return 2
    if args.jobs < 1:
        print(f"error: --jobs must be at least 1, got {args.jobs}", file=sys.stderr)
        return 2
    files = []
    for p in map(Path, args.paths):
        if p.is_dir():
            files += sorted(p.rglob("trials.mcap"))
        elif p.is_file():
            files.append(p)
        else:
            print(f"error: {p}: no such file or folder", file=sys.stderr)
            return 2
    if not files:
        print(f"error: no trials.mcap under {', '.join(args.paths)}", file=sys.stderr)
        return 2
    total, bad, unreadable, lines = 0, 0, 0, []
    for f, result in _rechecked(files, args.step, args.jobs):
        if isinstance(result, Exception):
            lines.append(f"{f}: unreadable ({type(result).__name__}: {result})")
            print(lines[-1])
            unreadable += 1
            continue
        n, false, step = result
        total, bad = total + n, bad + len(false)
        lines.append(f"{f}: {n} successes re-checked at step {step:g}, {len(false)} false")
        lines += [f"  {qid}: {why}" for qid, why in false]
        print("\n".join(lines[-1 - len(false) :]))
    summary = f"{len(files)} files, {total} successes re-checked, false successes {bad}, unreadable {unreadable}"
    print(summary)
    if args.out is not None:
        print(f"written: {write_report(args.out, total, bad, unreadable, summary, lines, argv)}")
    return 1 if bad or unreadable else 0


def _recheck_or_error(path: Path, step: float | None, share: tuple[int, int] = (0, 1)):
    """_recheck_share's result, or the error that makes the file unreadable (returned, so that a
    worker process hands it back like a result)."""
    try:
        return _recheck_share(path, step, share)
    except (OSError, ValueError, KeyError, TypeError) as e:
        return e


def _merged(parts: list):
    """One file's result (recheck_file's) from its shares' (the first error if a share failed),
    its false successes in the log's order."""
    if errors := [p for p in parts if isinstance(p, Exception)]:
        return errors[0]
    false = sorted(x for _, f, _ in parts for x in f)
    return sum(n for n, _, _ in parts), [(qid, why) for _, qid, why in false], parts[0][2]


def _rechecked(files: list[Path], step: float | None, jobs: int):
    """(file, result or error) in the files' order; `jobs` > 1: that many processes, started
    fresh (spawn), so each builds its own collision world; fewer files than jobs: each file's
    successes shared among its processes."""
    if jobs == 1:
        yield from ((f, _merged([_recheck_or_error(f, step)])) for f in files)
        return
    n = max(1, jobs // len(files))
    tasks = [(f, (i, n)) for f in files for i in range(n)]
    with process_pool(min(jobs, len(tasks))) as pool:
        results = pool.map(_recheck_or_error, [f for f, _ in tasks], [step] * len(tasks), [s for _, s in tasks])
        for f in files:
            yield f, _merged([next(results) for _ in range(n)])


def write_report(out: Path, total: int, bad: int, unreadable: int, summary: str, lines: list[str], argv) -> Path:
    """OUT/recheck.md: "N successes, N verified", per file, with where and when it ran; the file
    a report folder's "0 false successes" is quoted from."""
    from harness.core.provenance import generated_by, machine_info

    m = machine_info()
    argv = sys.argv[1:] if argv is None else argv
    out.mkdir(parents=True, exist_ok=True)
    text = [
        "# Re-check of the logged successes",
        "",
        generated_by(f"python -m harness.recheck {' '.join(map(str, argv))}", m),
        "",
        f"**{total} successes, {total - bad} verified** ({bad} false, {unreadable} files unreadable). {summary}.",
        "",
        "```",
        *lines,
        "```",
        "",
    ]
    (out / RECHECK_FILE).write_text("\n".join(text))
    return out / RECHECK_FILE


if __name__ == "__main__":
    sys.exit(main())
