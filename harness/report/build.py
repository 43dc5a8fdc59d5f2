"""write_report: read the logs once and write every output of the report into one directory, one
that the report made (it marks it with MARKER) or that it is told to write into anyway (force): a
report never overwrites a folder by accident."""

from __future__ import annotations

import shlex
from collections.abc import Iterable, Sequence
from pathlib import Path

from harness.report.arena import write_benchmark_db
from harness.report.commands import missing_runs
from harness.report.diagnostics import diagnostics_table, render_diagnostics
from harness.report.equal_quality import equal_quality_table
from harness.report.facts import planner_facts
from harness.report.figures import write_figures
from harness.report.load import duplicate_warnings, label_variants, load, queries_frame
from harness.report.problem_sets import problem_set_table, render_problem_sets
from harness.report.readme import provenance, readme_text, reference_notes
from harness.report.render import (
    render_ablations,
    render_equal_quality,
    render_quality,
    render_success_cost,
    render_table1,
)
from harness.report.tables import (
    ablation_table,
    load_paper,
    loaded_warnings,
    main_planners,
    quality_table,
    results_table,
    success_cost,
    table1,
)

MARKER = ".mpnet-report"


class OutputTaken(Exception):
    """The output folder exists, holds files and was not made by the report (no MARKER in it)."""


def default_out(inputs: Sequence[str | Path]) -> Path:
    """Where a report goes unless told: `report/` in the first input directory (beside a file
    given as input), never the committed reports/."""
    first = Path(inputs[0]) if inputs else Path(".")
    return (first.parent if first.is_file() else first) / "report"


def check_out(out: Path, force: bool) -> None:
    """Raise OutputTaken unless out is missing, empty, marked as the report's own, or force."""
    if force or not out.exists() or (out / MARKER).is_file():
        return
    if not out.is_dir():
        raise OutputTaken(f"{out} exists and is not a folder")
    if any(out.iterdir()):
        raise OutputTaken(
            f"{out} exists and was not written by the report (no {MARKER} in it): "
            "pass --force to write into it anyway, or name another --out"
        )


def claim_out(out: Path) -> None:
    """Make out and mark it as the report's, so that the next report may write into it again."""
    out.mkdir(parents=True, exist_ok=True)
    (out / MARKER).write_text(
        "Written by `python -m harness.report`: a report run into this folder again overwrites its outputs.\n"
    )


def _noted(text: str, facts, prefix: str = "") -> str:
    """A table's text with the dirty-tree note under it when a planner it may show is marked."""
    note = facts.dirty_note()
    return text if not note else f"{text.rstrip()}\n\n{prefix}{note}\n"


def write_report(
    dirs: Iterable[str | Path],
    out: str | Path | None = None,
    paper: bool = False,
    force: bool = False,
    labels: Sequence[tuple[str, str | Path]] = (),
) -> dict:
    """Read the trial logs under dirs (and under each labelled directory of labels: (label, dir)
    pairs, whose planners are shown as `planner [label]`) and write every output into out
    (default_out when None). Raises OutputTaken before reading anything when out is not the
    report's to write (check_out). Returns a summary dict (files, skipped, warnings, queries,
    outputs, out); files == 0 or queries == 0 means nothing was written."""
    dirs = list(dirs)
    out = Path(out) if out is not None else default_out(dirs + [d for _, d in labels])
    check_out(out, force)
    files, warns, skipped = load(dirs, labels)
    label_variants(files)
    summary = {"files": len(files), "skipped": skipped, "warnings": warns, "queries": 0, "outputs": [], "out": out}
    if not files or not any(tf.queries for tf in files):
        return summary
    facts, fact_warns = planner_facts(files)
    warns += fact_warns
    q = queries_frame(files)
    summary["queries"] = len(q)
    warns += duplicate_warnings(q, files, facts)
    claim_out(out)
    res = results_table(q, facts)
    warns += loaded_warnings(res)
    res.assign(dirty=res["planner"].map(lambda p: p in facts.dirty)).to_csv(out / "results.csv", index=False)
    written = [out / "results.csv"]
    main_res = main_planners(res, facts)
    paper_df = load_paper() if paper else None
    t, layout = table1(main_res, facts, paper_df)
    t.to_csv(out / "table1.csv", index=False)
    md, tex = render_table1(t, layout, paper, facts, main_res, paper_df)
    summary["missing"] = missing = missing_runs([tf.run for tf in files if tf.label is None])
    if missing:  # the columns without runs, and the command that makes them
        md += "\nWhat these runs lack:\n\n" + "".join(f"- {line}\n" for line in missing)
    (out / "table1.md").write_text(_noted(md, facts))
    (out / "table1.tex").write_text(_noted(tex, facts, "% "))
    sc = success_cost(main_res)
    sc.to_csv(out / "success_cost.csv", index=False)
    md, tex = render_success_cost(sc, paper, facts)
    (out / "success_cost.md").write_text(_noted(md, facts))
    (out / "success_cost.tex").write_text(_noted(tex, facts, "% "))
    written += [
        out / n
        for n in ("table1.md", "table1.tex", "table1.csv", "success_cost.md", "success_cost.tex", "success_cost.csv")
    ]
    refs = reference_notes(q, files)
    eq, eq_warns = equal_quality_table(q, files, facts)
    warns += eq_warns
    optional = {
        "quality": (
            quality_table(res),
            lambda d: render_quality(
                d, refs or ["no query in these logs has a reference cost: the quality columns are blank."], facts
            ),
        ),
        "ablations": (ablation_table(res, facts), lambda d: render_ablations(d, facts)),
        "equal_quality": (eq, lambda d: render_equal_quality(d, facts)),
        "diagnostics": (diagnostics_table(files), lambda d: render_diagnostics(d, facts)),
        "problem_sets": (problem_set_table(q, facts), lambda d: render_problem_sets(d, facts)),
    }
    extra = {"reference_notes": refs, "missing": missing}
    for name, (df, render) in optional.items():
        for ext in ("md", "csv", "tex"):  # an earlier report's table must not outlive its data
            (out / f"{name}.{ext}").unlink(missing_ok=True)
        extra[name] = not df.empty
        if df.empty:
            continue
        df.to_csv(out / f"{name}.csv", index=False)
        (out / f"{name}.md").write_text(_noted(render(df), facts))
        written += [out / f"{name}.md", out / f"{name}.csv"]
    shown = set(main_res["planner"])
    summary["figures"], fig_warns = write_figures(main_res, q[q["planner"].isin(shown)], files, out / "figures", facts)
    warns += fig_warns
    write_benchmark_db(q, files, out / "benchmark.db", facts)
    args = [str(d) for d in dirs] + [a for lab, d in labels for a in ("--label", f"{lab}={d}")]
    args += ["--out", str(out)] + (["--paper"] if paper else [])
    (out / "README.md").write_text(
        readme_text(len(files), len(q), paper, provenance(files), shlex.join(args), warns, extra, str(out))
    )
    summary["outputs"] = written + [out / "benchmark.db", out / "README.md"]
    return summary
