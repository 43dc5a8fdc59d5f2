"""`python -m harness.report DIR... [--label NAME=DIR]... [--out OUT] [--force] [--paper]`: the command
line of the report."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.report.build import MARKER, OutputTaken, default_out, write_report

EPILOG = f"""\
The report goes to DIR/report/ (the first DIR's) unless --out names another folder. It never
writes into an existing folder that it did not make (a folder it made holds a {MARKER} file, so
running it again into its own output is fine) unless --force is given. The committed top-level
report is regenerated only by naming it: --out reports/table1.
"""


def parse_labels(values: list[str]) -> list[tuple[str, str]]:
    """`NAME=DIR` values as (NAME, DIR) pairs; ValueError naming the first malformed one."""
    out = []
    for v in values:
        name, sep, d = v.partition("=")
        if not sep or not name.strip() or not d or any(c in name for c in "[]"):
            raise ValueError(f"--label {v!r}: expected NAME=DIR (a non-empty NAME without brackets)")
        out.append((name.strip(), d))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m harness.report",
        description="Table I, figures and an OMPL benchmark database from trial logs.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("dirs", nargs="*", metavar="DIR", help="directories searched recursively for trials.mcap")
    ap.add_argument(
        "--label",
        action="append",
        default=[],
        metavar="NAME=DIR",
        help="also read DIR's logs, as runs of their own: their planners are shown as `planner [NAME]` in every "
        "table and figure, never pooled with the same planner, env and seed from another DIR (repeatable)",
    )
    ap.add_argument(
        "--out", default=None, help="output folder (default: DIR/report/ of the first DIR; reports/ only when named)"
    )
    ap.add_argument("--force", action="store_true", help="write into --out even if the report did not make it")
    ap.add_argument("--paper", action="store_true", help="put the paper's Table I numbers beside ours")
    args = ap.parse_args(argv)
    try:
        labels = parse_labels(args.label)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    inputs = args.dirs + [d for _, d in labels]
    if not inputs:
        print("error: no input: name at least one DIR (or --label NAME=DIR)", file=sys.stderr)
        return 2
    out = Path(args.out) if args.out else default_out(inputs)
    try:
        s = write_report(args.dirs, out, args.paper, args.force, labels)
    except OutputTaken as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    except OSError as e:
        print(f"error: cannot write the report to {out}: {e.strerror or e}", file=sys.stderr)
        return 1
    for w in s["warnings"]:
        print(w, file=sys.stderr)
    if not s["files"]:
        print(f"error: no readable trials.mcap under {', '.join(inputs)}", file=sys.stderr)
        return 1
    if not s["queries"]:
        print(f"error: no queries in the {s['files']} readable trials.mcap under {', '.join(inputs)}", file=sys.stderr)
        return 1
    print(f"read {s['files']} trial logs ({s['queries']} queries), skipped {s['skipped']}")
    for line in s.get("missing", []):
        print(line)
    tables = "".join(
        f", {n}.{{md,csv}}" for n in ("quality", "ablations", "equal_quality") if out / f"{n}.csv" in s["outputs"]
    )
    print(
        f"wrote {out}/: results.csv, table1.{{md,tex,csv}}, success_cost.{{md,tex,csv}}{tables}, benchmark.db, "
        f"README.md, figures/ ({len(s['figures']) // 2} figures)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
