"""`--label NAME=DIR` in Table I (a BIT*/MPNet (NR) ratio per label, the labelled planners after
the paper's layout) and in the time-to-equal-quality table (a row per label, side by side)."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from harness.report.equal_quality import equal_quality_table
from harness.report.facts import planner_facts
from harness.report.load import load, queries_frame
from harness.report.render import render_equal_quality, render_table1
from harness.report.tables import load_paper, main_planners, results_table, table1
from tests.harness.report._helpers import Q, eq_config, write_log

PAPER_BLOCK = [("time", p) for p in ("mpnet_nr", "mpnet_hr", "informed_rrt_star", "bit_star")] + [("ratio", None)]


def _table1(dirs, labels=(), paper=None):
    files, _, _ = load(dirs, labels)
    facts, _ = planner_facts(files)
    res = main_planners(results_table(queries_frame(files), facts), facts)
    t, layout = table1(res, facts, paper)
    return t, layout, render_table1(t, layout, paper is not None, facts, res, paper)[0]


def _runs(root, nr_times, bit_times):
    """s2d seen: MPNet (NR) and BIT* runs (seed 0) under root with the given query times."""
    if nr_times:
        write_log(root / "nr", "s2d", "mpnet_nr", 0, [Q("seen", "0", i, True, t) for i, t in enumerate(nr_times)])
    write_log(root / "bit", "s2d", "bit_star", 0, [Q("seen", "0", i, True, t) for i, t in enumerate(bit_times)])
    return root


@pytest.fixture()
def label_logs(tmp_path):
    """Unlabelled runs (BIT*/NR = 2.0/0.2), label A (1.5/0.5), B (0.6/0.3), C (BIT* only)."""
    return {
        None: _runs(tmp_path / "plain", [0.1, 0.3], [1.0, 3.0]),
        "A": _runs(tmp_path / "a", [0.5, 0.5], [1.0, 2.0]),
        "B": _runs(tmp_path / "b", [0.2, 0.4], [0.6, 0.6]),
        "C": _runs(tmp_path / "c", [], [4.0]),
    }


def test_table1_ratio_per_label(label_logs):
    """Each label's BIT*/MPNet (NR) is its own BIT* over its own MPNet (NR), in a column after that
    label's planners; a label without MPNet (NR) has none; the unlabelled layout comes first."""
    labels = [(k, v) for k, v in label_logs.items() if k]
    t, layout, md = _table1([label_logs[None]], labels)
    assert layout == PAPER_BLOCK + [
        ("time", "mpnet_nr [A]"),
        ("time", "bit_star [A]"),
        ("ratio", "A"),
        ("time", "mpnet_nr [B]"),
        ("time", "bit_star [B]"),
        ("ratio", "B"),
        ("time", "bit_star [C]"),
    ]
    row = t.iloc[0]
    assert row["bit_star_over_mpnet_nr"] == pytest.approx(10.0)
    assert row["bit_star_over_mpnet_nr [A]"] == pytest.approx(3.0)
    assert row["bit_star_over_mpnet_nr [B]"] == pytest.approx(2.0)
    assert "bit_star_over_mpnet_nr [C]" not in t
    head, _, first = md.splitlines()[2:5]
    assert head == (
        "| Env | Split | MPNet (NR) | MPNet (HR) | Informed-RRT* | BIT* | BIT*/MPNet (NR) | MPNet (NR) [A] | "
        "BIT* [A] | BIT*/MPNet (NR) [A] | MPNet (NR) [B] | BIT* [B] | BIT*/MPNet (NR) [B] | BIT* [C] |"
    )
    cells = [c.strip().removeprefix("≈ ") for c in first.strip("|").split("|")]
    assert cells[6] == "10.0" and cells[9] == "3.00" and cells[12] == "2.00" and cells[13] == "4.00 ± 0.00"
    assert "--label NAME=DIR" in md


def test_table1_layout_without_labels_is_the_papers(label_logs, tmp_path):
    """No --label: the paper's four planners, the ratio, then the other planners, as before."""
    plain = label_logs[None]
    write_log(plain / "rrtc", "s2d", "rrt_connect", 0, [Q("seen", "0", 0, True, 0.7)])
    t, layout, _ = _table1([plain])
    assert layout == PAPER_BLOCK + [("time", "rrt_connect")]
    time_cols = [f"{p}_{s}" for _, p in PAPER_BLOCK[:4] for s in ("time_mean_s", "time_std_s")]
    assert list(t.columns) == ["env", "split", "source"] + time_cols + [
        "bit_star_over_mpnet_nr",
        "rrt_connect_time_mean_s",
        "rrt_connect_time_std_s",
    ]


def test_table1_only_labelled_runs(label_logs):
    """Every run labelled: no empty columns of the paper's layout, unless the paper's rows are asked for."""
    labels = [("A", label_logs["A"]), ("B", label_logs["B"])]
    t, layout, _ = _table1([], labels)
    assert layout[0] == ("time", "mpnet_nr [A]") and ("ratio", None) not in layout
    assert list(t["source"]) == ["ours"]
    t, layout, md = _table1([], labels, load_paper())
    assert layout[:5] == PAPER_BLOCK and ("ratio", "B") in layout
    assert list(t["source"]) == ["ours", "paper"] and math.isnan(t.iloc[0]["bit_star_over_mpnet_nr"])
    assert t.iloc[0]["bit_star_over_mpnet_nr [B]"] == pytest.approx(2.0)


def _eq_run(root, times, target_times):
    """A bit_star_to_nr run: s2d seen, every query reached at MPNet (NR)'s cost."""
    stats = [{"target_planner": "mpnet_nr", "target_cost": 10.0, "target_time_s": t} for t in target_times]
    queries = [Q("seen", "0", i, True, t, cost=10.0, stats=s) for i, (t, s) in enumerate(zip(times, stats))]
    write_log(root / "to_nr", "s2d", "bit_star_to_nr", 0, queries, config=eq_config("bit_star_to_nr"))
    return root


def test_equal_quality_row_per_label(tmp_path):
    """Labelled time-to-equal-quality runs are not pooled: one row per label, after the unlabelled
    one, each against its own label's MPNet (NR)."""
    plain = _eq_run(tmp_path / "plain", [1.0, 1.0, 1.0], [0.1, 0.1, 0.1])
    a = _eq_run(tmp_path / "a", [2.0, 2.0, 2.0], [0.5, 0.5, 0.5])
    b = _eq_run(tmp_path / "b", [3.0, 3.0, 3.0], [1.0, 1.0, 1.0])
    files, _, _ = load([plain], [("B", b), ("A", a)])
    facts, _ = planner_facts(files)
    eq, warns = equal_quality_table(queries_frame(files), files, facts)
    assert warns == []
    assert eq["label"].tolist() == ["", "A", "B"]
    assert eq["planner"].tolist() == ["bit_star_to_nr", "bit_star_to_nr [A]", "bit_star_to_nr [B]"]
    assert eq["target_planner"].tolist() == ["mpnet_nr", "mpnet_nr [A]", "mpnet_nr [B]"]
    assert eq["queries"].tolist() == [3, 3, 3]
    assert eq["time_to_reach_median_s"].tolist() == [1.0, 2.0, 3.0]
    assert eq["time_ratio"].tolist() == pytest.approx([10.0, 4.0, 3.0])
    md = render_equal_quality(eq, facts)
    assert "| Simple 2D | seen | BIT* | cost ≤ 1 × MPNet (NR)'s | 0 | 3 |" in md
    assert "|  |  | BIT* [A] | cost ≤ 1 × MPNet (NR) [A]'s | 0 | 3 |" in md
    assert "|  |  | BIT* [B] | cost ≤ 1 × MPNet (NR) [B]'s | 0 | 3 |" in md


@pytest.mark.slow  # six tiny runs (MPNet trained at tiny scale once per session), then the report
def test_labelled_report_from_tiny_runs(tmp_path, run_cli):
    """Two folders of real tiny runs (MPNet (NR), BIT*, BIT* to NR; seeds 0 and 1) given as labels:
    Table I has each label's ratio after its planners, equal_quality.csv a row per label."""
    for name, seed in (("A", 0), ("B", 1)):
        run_cli(
            "harness",
            "-m",
            "+env=s2d",
            "+planner=mpnet_nr,bit_star,bit_star_to_nr",
            "scale=tiny",
            f"seed={seed}",
            "budget_s=1",  # BIT* chasing NR's exact cost gives up after 1 s, not 10
            "progress=false",
            "rerun=false",
            f"hydra.sweep.dir={tmp_path / name}",
        )
    out = tmp_path / "report"
    run_cli("harness.report", "--label", f"A={tmp_path / 'A'}", "--label", f"B={tmp_path / 'B'}", "--out", str(out))
    res = pd.read_csv(out / "results.csv").set_index(["split", "planner"])
    t1 = pd.read_csv(out / "table1.csv")
    expected = []
    for k in "AB":
        expected += [f"{p} [{k}]_time_{s}_s" for p in ("mpnet_nr", "bit_star") for s in ("mean", "std")]
        expected.append(f"bit_star_over_mpnet_nr [{k}]")
    assert list(t1.columns) == ["env", "split", "source"] + expected  # every run is labelled
    for r in t1.to_dict("records"):
        for k in "AB":
            bit, nr = (res.loc[(r["split"], f"{p} [{k}]"), "time_mean_s"] for p in ("bit_star", "mpnet_nr"))
            assert r[f"bit_star_over_mpnet_nr [{k}]"] == pytest.approx(bit / nr, nan_ok=True)
    header = (out / "table1.md").read_text().splitlines()[2].replace(" †", "")  # † marks a dirty tree's runs
    assert header.endswith("| BIT* [A] | BIT*/MPNet (NR) [A] | MPNet (NR) [B] | BIT* [B] | BIT*/MPNet (NR) [B] |")
    eq = pd.read_csv(out / "equal_quality.csv")
    assert list(zip(eq["split"], eq["label"], eq["target_planner"])) == [
        ("seen", "A", "mpnet_nr [A]"),
        ("seen", "B", "mpnet_nr [B]"),
        ("unseen", "A", "mpnet_nr [A]"),
        ("unseen", "B", "mpnet_nr [B]"),
    ]
    assert (eq["queries"] == 4).all()
    emd = (out / "equal_quality.md").read_text().replace(" †", "")  # as table1.md's header
    assert "| BIT* [A] | cost ≤ 1 × MPNet (NR) [A]'s |" in emd and "| BIT* [B] | cost ≤ 1 × MPNet (NR) [B]'s |" in emd


def test_a_run_of_its_own_recipe_is_labelled_by_it_never_pooled():
    """`+planner=mpnet_nr +planner.networks.bounded=true` is not mpnet_nr's plain networks: the
    report labels it by the options its name does not say (a named variant's own are said)."""
    from harness.report.load import recipe_label

    def run(planner, networks):
        return {"planner": planner, "facts": {"planner_config": {"name": planner, "networks": networks}}}

    assert recipe_label(run("mpnet_nr", None)) is None
    assert recipe_label(run("mpnet_nr", {"bounded": True, "waypoint_step": 0.5})) == "dense+bounded"
    assert recipe_label(run("mpnet_nr_dense", {"waypoint_step": 0.5, "equal_steps": True})) is None
    assert recipe_label(run("mpnet_nr_zeros", {"bounded": True})) == "bounded"
    assert recipe_label({"planner": "bit_star"}) is None


def test_a_run_of_its_own_recipe_is_one_row_of_the_ablations_beside_the_plain_one(tmp_path):
    """Its own base (the label), listed once: the ablation table once showed it twice."""
    import yaml

    from harness.log.facts import facts_from_config
    from harness.report.tables import ablation_table
    from tests.harness.report._helpers import planner_config

    qs = [Q("seen", "0", i, i % 2 == 0, 0.1) for i in range(4)]
    write_log(tmp_path / "plain", "s2d", "mpnet_nr", 0, qs)
    write_log(tmp_path / "rnd", "s2d", "mpnet_nr_random", 0, qs)
    config = planner_config("mpnet_nr", networks={"bounded": True})
    write_log(tmp_path / "b", "s2d", "mpnet_nr", 0, qs, config=config, facts=facts_from_config(yaml.safe_load(config)))
    files, _, _ = load([tmp_path])
    assert sorted(tf.planner for tf in files) == ["mpnet_nr", "mpnet_nr [bounded]", "mpnet_nr_random"]
    facts, _ = planner_facts(files)
    rows = list(ablation_table(results_table(queries_frame(files), facts), facts)["planner"])
    assert sorted(rows) == ["mpnet_nr", "mpnet_nr [bounded]", "mpnet_nr_random"]
