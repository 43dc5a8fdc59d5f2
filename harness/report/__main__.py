"""`python -m harness.report DIR... [--out OUT] [--paper]`: the command line of the report."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.report.build import write_report


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m harness.report", description="Table I, figures and an OMPL benchmark database from trial logs."
    )
    ap.add_argument("dirs", nargs="+", metavar="DIR", help="directories searched recursively for trials.mcap")
    ap.add_argument("--out", default="reports", help="output directory (default: reports/)")
    ap.add_argument("--paper", action="store_true", help="put the paper's Table I numbers beside ours")
    args = ap.parse_args(argv)
    try:
        s = write_report(args.dirs, args.out, args.paper)
    except OSError as e:
        print(f"error: cannot write the report to {args.out}: {e.strerror or e}", file=sys.stderr)
        return 1
    for w in s["warnings"]:
        print(w, file=sys.stderr)
    if not s["files"]:
        print(f"error: no readable trials.mcap under {', '.join(args.dirs)}", file=sys.stderr)
        return 1
    if not s["queries"]:
        print(
            f"error: no queries in the {s['files']} readable trials.mcap under {', '.join(args.dirs)}", file=sys.stderr
        )
        return 1
    out = Path(args.out)
    print(f"read {s['files']} trial logs ({s['queries']} queries), skipped {s['skipped']}")
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
