"""`python -m harness.report.summary [--reports reports] [--readme README.md]`: the bottom line.

One short table (per env: success, median time and path cost of MPNet-NR, MPNet-HR, BIT*,
RRT-Connect, the compiled RRT-Connect and random proposals in MPNet's loop) and three sentences
of what it means, read from the committed reports' `results.csv` files (SOURCES: a row's own
report, then its `extra` reports for the planners it lacks, their cells marked; the rows are
harness/report/summary.yaml) and written into
reports/summary.md and between the README's markers. Nothing is typed by hand: a changed
report changes the summary, and tests/harness/report/test_summary.py fails while the README's copy is stale.

Success is of the valid queries (MotionBenchMaker's starts or goals that collide with our
sphere model are `invalid_query` and left out, as VAMP counts them); time is the median over
solved queries, planning included; cost is the median ratio of the planner's path cost to
BIT*'s on the queries both solve (BIT* stops at its first solution)."""

from __future__ import annotations

import argparse
import csv
import re
import sys
from dataclasses import dataclass
from pathlib import Path

from harness.report.own_data import own_table

BEGIN, END = "<!-- summary:begin -->", "<!-- summary:end -->"


@dataclass(frozen=True)
class Source:
    """One row: an env's split in one committed report folder (and, for planners that report has
    no run of, in `extra` folders: another session's runs, so their cells are marked)."""

    label: str
    folder: str  # under reports/
    env: str
    split: str
    extra: tuple[str, ...] = ()
    short: str = ""  # its name in the sentences (default: the label up to its comma)

    @property
    def name(self) -> str:
        return self.short or self.label.split(",")[0]


SOURCES = tuple(Source(**{**row, "extra": tuple(row.get("extra", ()))}) for row in own_table("summary"))
PLANNERS = (
    ("MPNet-NR", "mpnet_nr"),
    ("MPNet-HR", "mpnet_hr"),
    ("BIT*", "bit_star"),
    ("RRT-Connect", "rrt_connect"),
    ("RRT-Connect (compiled)", "rrt_connect_compiled"),
    ("random proposals", "mpnet_nr_random"),
)


@dataclass(frozen=True)
class Cell:
    seeds: int
    solved: int
    valid: int
    time_s: float | None
    cost: float | None  # median cost / BIT*'s on queries both solve
    extra: str | None = None  # the extra folder the cell comes from (None: the row's own)

    @property
    def rate(self) -> float:
        return self.solved / self.valid if self.valid else 0.0


def pct(rate: float) -> str:
    """A success rate to one decimal (99.8%, not a rounded 100%); exact ends as they are."""
    return f"{rate:.0%}" if rate in (0.0, 1.0) else f"{rate * 100:.1f}%"


def _float(value: str) -> float | None:
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


def _invalid(failures: str) -> int:
    m = re.search(r"invalid_query: (\d+)", failures or "")
    return int(m.group(1)) if m else 0


def read_tables(reports: Path) -> dict[str, list[dict]]:
    """Every report's results.csv rows the summary reads, by folder (_folders)."""
    tables = {}
    for folder in _folders():
        with open(reports / folder / "results.csv", newline="") as f:
            tables[folder] = list(csv.DictReader(f))
    return tables


def _rows_of(table: list[dict], src: Source) -> list[dict]:
    return [r for r in table if r["env"] == src.env and r["split"] == src.split]


def read_rows(reports: Path, tables: dict[str, list[dict]] | None = None) -> dict[Source, dict[str, Cell]]:
    """Each source's cells by planner (a planner without a row in its reports is absent): from
    the row's own report, then from its extra ones for the planners it lacks."""
    tables = read_tables(reports) if tables is None else tables
    out: dict[Source, dict[str, Cell]] = {}
    for src in SOURCES:
        cells: dict[str, Cell] = {}
        for folder in (src.folder, *src.extra):
            for row in _rows_of(tables[folder], src):
                if row["planner"] in cells:
                    continue
                valid = int(row["queries"]) - _invalid(row.get("failures", ""))
                cost = 1.0 if row["planner"] == "bit_star" else _float(row.get("cost_over_bit_star_median"))
                time = _float(row["time_median_s"])
                extra = None if folder == src.folder else folder
                cells[row["planner"]] = Cell(int(row["seeds"]), int(row["successes"]), valid, time, cost, extra)
        out[src] = cells
    return out


def _folders() -> list[str]:
    """Every report the summary reads, rows' own first."""
    return list(dict.fromkeys([s.folder for s in SOURCES] + [f for s in SOURCES for f in s.extra]))


def _cell(c: Cell | None) -> str:
    if c is None:
        return "—"
    time = "—" if c.time_s is None else f"{c.time_s * 1e3:.2g} ms" if c.time_s < 1 else f"{c.time_s:.2g} s"
    cost = "—" if c.cost is None else f"{c.cost:.2f}"
    return f"{pct(c.rate)} · {time} · {cost}" + (" †" if c.extra else "")


def _marked(tables: dict[str, list[dict]], rows: dict[Source, dict[str, Cell]]) -> str:
    """What † means: the reports the marked cells come from, and MPNet-NR's median time in each
    (the time measured beside them)."""
    beside = []
    for src in SOURCES:
        for folder in sorted({c.extra for c in rows[src].values() if c.extra}):
            nr = [r for r in _rows_of(tables[folder], src) if r["planner"] == "mpnet_nr"]
            time = _float(nr[0]["time_median_s"]) if nr else None
            said = f"MPNet-NR there {time * 1e3:.2g} ms" if time is not None else "no MPNet-NR there"
            beside.append(f"[{folder}/](reports/{folder}/README.md) for {src.env} ({said})")
    if not beside:
        return ""
    return (
        f"†: from another report, run in another session than the row's own: {'; '.join(beside)}. Its time "
        "compares with the runs beside it there, not with this row's; its cost is over that report's BIT* "
        "(— where it has none)."
    )


def _revisions(reports: Path, folders: list[str]) -> list[str]:
    """Each folder's 'Git revision of the runs' line, as its README says it."""
    out = []
    for folder in folders:
        try:
            text = (reports / folder / "README.md").read_text()
        except OSError:
            continue
        m = re.search(r"Git revision of the runs: ([^\n]+)", text)
        out.append(f"[{folder}/]({folder}/README.md): {m.group(1).strip() if m else 'not said'}")
    return out


def _seeds(rows: dict[Source, dict[str, Cell]]) -> str:
    seeds = sorted({c.seeds for cells in rows.values() for c in cells.values()})
    return "One seed" if seeds == [1] else f"Seeds per run: {', '.join(map(str, seeds))}"


def sentences(rows: dict[Source, dict[str, Cell]]) -> list[str]:
    """Three sentences read off the table: the generated envs, the arm, the ablation."""
    flat = [s for s in SOURCES if s.env in ("s2d", "c2d", "c3d", "rigid")]
    arm = [s for s in SOURCES if s.env not in ("s2d", "c2d", "c3d", "rigid")]

    def rng(srcs, planner) -> str:
        rates = [rows[s][planner].rate for s in srcs if planner in rows[s]]
        if not rates:
            return "no runs"
        lo, hi = min(rates), max(rates)
        return pct(lo) if pct(lo) == pct(hi) else f"{pct(lo)}–{pct(hi)}"

    out = [
        f"On the paper's four environments MPNet-HR solves {rng(flat, 'mpnet_hr')} of unseen-workspace queries "
        f"and MPNet-NR {rng(flat, 'mpnet_nr')}, against BIT*'s {rng(flat, 'bit_star')} within the same budget; "
        "our BIT* and RRT-Connect are OMPL's C++, the paper's baselines were Python: time ratios are not the paper's."
    ]
    words = []
    for s in arm:
        r = rows[s]
        words.append(
            f"{s.label}: MPNet-NR {_rate(r, 'mpnet_nr')}, MPNet-HR {_rate(r, 'mpnet_hr')}, "
            f"BIT* {_rate(r, 'bit_star')}, RRT-Connect {_rate(r, 'rrt_connect')} "
            f"(compiled: {_rate(r, 'rrt_connect_compiled')})"
        )
    out.append("On the arm: " + "; ".join(words) + ".")
    ahead = [s for s in SOURCES if _beats(rows[s], "mpnet_nr_random", "mpnet_nr")]
    if ahead:
        names = ", ".join(s.name for s in ahead)
        costs = [(rows[s]["mpnet_nr"].cost, rows[s]["mpnet_nr_random"].cost) for s in ahead]
        costs = [(a, b) for a, b in costs if a is not None and b is not None]
        tail = (
            f"; where they do, Pnet's paths are shorter (cost / BIT*'s {_span([a for a, _ in costs])} against "
            f"{_span([b for _, b in costs])}): the networks buy path quality there, not success."
            if costs
            else "."
        )
        out.append(f"Random proposals in MPNet's own loop (no network) solve more than MPNet-NR in {names}{tail}")
    else:
        out.append("Random proposals in MPNet's own loop (no network) solve fewer than MPNet-NR wherever both ran.")
    return out


def _beats(cells: dict[str, Cell], a: str, b: str) -> bool:
    return a in cells and b in cells and cells[a].rate > cells[b].rate


def _span(xs: list[float]) -> str:
    return f"{min(xs):.2f}" if round(min(xs), 2) == round(max(xs), 2) else f"{min(xs):.2f}–{max(xs):.2f}"


def _rate(cells: dict[str, Cell], planner: str) -> str:
    c = cells.get(planner)
    return "no runs" if c is None else pct(c.rate)


def _budget(reports: Path) -> str:
    """The per-query budget the source reports' READMEs state ("budget per query: 10.0 s")."""
    found = set()
    for folder in _folders():
        try:
            m = re.search(r"budget per query: ([^\n]+?) s\b", (reports / folder / "README.md").read_text())
        except OSError:
            m = None
        found.add(m.group(1) if m else "?")
    return "a " + " / ".join(f"{float(b):g}" if b != "?" else b for b in sorted(found)) + " s budget per query"


def render(reports: Path) -> str:
    tables = read_tables(reports)
    rows = read_rows(reports, tables)
    head = "| env | " + " | ".join(name for name, _ in PLANNERS) + " |"
    lines = [
        "## Where MPNet stands",
        "",
        "Each cell: success of valid queries · median time of the solved (planning included) · median path cost "
        f"/ BIT*'s on the queries both solve. {_seeds(rows)}, {_budget(reports)}, two CPU cores; "
        "— : no committed run. Generated by `python -m harness.report.summary` from the committed reports "
        "([reports/summary.md](reports/summary.md) says which); MPNet's networks trained only on generated "
        "workspaces, never on MotionBenchMaker's problems. The clock is not the same for all: MPNet's loop and the "
        "compiled RRT-Connect call the collision kernels directly, while BIT*, RRT-Connect and MPNet-HR's RRT* "
        "(OMPL's) call back into "
        'Python for every check ([docs/arm.md](docs/arm.md), "A fair clock"; `python -m harness.perf` says what '
        "a check costs each); and the runs come from several sessions on two-core VMs of two CPU models "
        "(Intel Xeon, AMD EPYC): a time compares best with one measured beside it in the same report.",
        "",
        head,
        "|" + " --- |" * (len(PLANNERS) + 1),
    ]
    for src in SOURCES:
        cells = rows[src]
        lines.append(f"| {src.label} | " + " | ".join(_cell(cells.get(p)) for _, p in PLANNERS) + " |")
    marked = _marked(tables, rows)
    lines += [""] + ([marked, ""] if marked else []) + [" ".join(sentences(rows)), ""]
    return "\n".join(lines)


def summary_file(reports: Path, table: str) -> str:
    folders = _folders()
    return "\n".join(
        [
            "# Summary",
            "",
            table.replace("](reports/", "](").replace("](docs/", "](../docs/"),
            "Sources (each report's README has its commands, machine and re-check):",
            "",
            *(f"- {line}" for line in _revisions(reports, folders)),
            "",
        ]
    )


def with_table(readme: str, table: str) -> str:
    """The README's text with `table` between its markers (ValueError without them)."""
    start, end = readme.find(BEGIN), readme.find(END)
    if start < 0 or end < start:
        raise ValueError(f"the README has no {BEGIN} ... {END} markers")
    return readme[: start + len(BEGIN)] + "\n" + table + readme[end:]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.report.summary", description=__doc__.split("\n")[0])
    ap.add_argument("--reports", type=Path, default=Path("reports"), help="the committed reports folder")
    ap.add_argument("--readme", type=Path, default=Path("README.md"), help="the README whose markers get the table")
    args = ap.parse_args(argv)
    try:
        table = render(args.reports)
        readme = with_table(args.readme.read_text(), table)
    except (OSError, KeyError, ValueError) as e:
        print(f"harness.report.summary: {e}", file=sys.stderr)
        return 2
    (args.reports / "summary.md").write_text(summary_file(args.reports, table))
    args.readme.write_text(readme)
    print(f"wrote {args.reports / 'summary.md'} and {args.readme}'s summary")
    return 0


if __name__ == "__main__":
    sys.exit(main())
