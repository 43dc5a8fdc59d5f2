"""The bottom line (harness.report.summary): generated from the committed reports, and the
README's copy is the generated one."""

from __future__ import annotations

import csv
import shutil

import pytest

from harness.report import summary


def _block(readme: str) -> str:
    start, end = readme.index(summary.BEGIN) + len(summary.BEGIN), readme.index(summary.END)
    return readme[start:end].strip("\n")


def test_readme_and_summary_md_are_the_committed_reports(repo):
    """Fails when a committed report changed and `python -m harness.report.summary` was not rerun."""
    table = summary.render(repo / "reports")
    assert _block((repo / "README.md").read_text()) == table.strip("\n")
    assert (repo / "reports" / "summary.md").read_text() == summary.summary_file(repo / "reports", table)


def _copy_reports(repo, tmp_path):
    for folder in summary._folders():
        dst = tmp_path / folder
        dst.mkdir(parents=True, exist_ok=True)  # a row's folder may sit inside another's
        for name in ("results.csv", "README.md"):
            shutil.copy(repo / "reports" / folder / name, dst / name)
    return tmp_path


def test_a_changed_figure_changes_the_table(repo, tmp_path):
    reports = _copy_reports(repo, tmp_path / "reports")
    before = summary.render(reports)
    path = reports / "stats" / "results.csv"
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    row = next(r for r in rows if (r["env"], r["split"], r["planner"]) == ("s2d", "unseen", "mpnet_nr"))
    row["successes"] = str(int(row["successes"]) - 100)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    after = summary.render(reports)
    assert after != before
    assert _block((repo / "README.md").read_text()) != after.strip("\n")


def test_success_counts_valid_queries_only(repo, tmp_path):
    """MotionBenchMaker's invalid queries (colliding start or goal) are out of the rate, as VAMP counts."""
    cells = summary.read_rows(repo / "reports")
    mbm = next(s for s in summary.SOURCES if s.env == "panda_mbm")
    with open(repo / "reports" / mbm.folder / "results.csv", newline="") as f:
        row = next(r for r in csv.DictReader(f) if r["planner"] == "mpnet_nr" and r["split"] == mbm.split)
    invalid = summary._invalid(row["failures"])
    assert invalid > 0 and cells[mbm]["mpnet_nr"].valid == int(row["queries"]) - invalid


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_command_writes_both_files_and_refuses_a_readme_without_markers(repo, tmp_path, run_cli):
    """`python -m harness.report.summary` as the README runs it (here on copies)."""
    reports = _copy_reports(repo, tmp_path / "reports")
    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n\n{summary.BEGIN}\nold\n{summary.END}\n\nafter\n")
    run_cli("harness.report.summary", "--reports", str(reports), "--readme", str(readme))
    text = readme.read_text()
    assert "old" not in text and text.endswith(f"{summary.END}\n\nafter\n") and "| env | MPNet-NR" in text
    assert (reports / "summary.md").read_text().startswith("# Summary")
    readme.write_text("# no markers\n")
    assert summary.main(["--reports", str(reports), "--readme", str(readme)]) == 2


@pytest.mark.parametrize("folder", sorted({s.folder for s in summary.SOURCES}))
def test_every_source_report_has_the_planners_it_is_read_for(repo, folder):
    """Each row's report has MPNet-NR and a classical planner, BIT* or RRT-Connect (a renamed env or
    split would leave a row of dashes; panda_mbm_mbm's BIT* waits for its rerun with the retrained networks)."""
    cells = summary.read_rows(repo / "reports")
    for src in (s for s in summary.SOURCES if s.folder == folder):
        assert "mpnet_nr" in cells[src] and {"bit_star", "rrt_connect"} & set(cells[src]), src.label


def test_an_extra_report_fills_only_the_planners_a_row_lacks_and_its_cells_are_marked(repo, tmp_path):
    """The compiled RRT-Connect's arm cells come from their own reports (another session's runs):
    marked †, with MPNet-NR's time there named; a planner the row's own report has is never
    taken from an extra one."""
    reports = _copy_reports(repo, tmp_path / "reports")
    rows = summary.read_rows(reports)
    tables = summary.read_tables(reports)
    for src in (s for s in summary.SOURCES if s.extra):
        cells = rows[src]
        own = {r["planner"] for r in summary._rows_of(tables[src.folder], src)}
        assert cells["rrt_connect_compiled"].extra == src.extra[-1]  # the compiled planner's own report
        assert own and all(cells[p].extra is None for p in own if p in cells)
        assert all(cells[p].extra in src.extra for p in cells if p not in own)
        assert summary._cell(cells["rrt_connect_compiled"]).endswith(" †")
    table = summary.render(reports)
    assert "†: from another report" in table and "MPNet-NR there" in table
    # the row's own report gets a compiled run: its cell is that one, unmarked
    mbm = next(s for s in summary.SOURCES if s.env == "panda_mbm")
    path = reports / mbm.folder / "results.csv"
    with open(path, newline="") as f:
        own = list(csv.DictReader(f))
    with open(reports / mbm.extra[-1] / "results.csv", newline="") as f:
        compiled = next(r for r in csv.DictReader(f) if r["planner"] == "rrt_connect_compiled")
    compiled = {k: compiled.get(k, "") for k in own[0]} | {"successes": "1"}
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(own[0]))
        w.writeheader()
        w.writerows([*own, compiled])
    cell = summary.read_rows(reports)[mbm]["rrt_connect_compiled"]
    assert cell.extra is None and cell.solved == 1
