"""`python -m harness.report` (docs/reports.md): statistics from known logs, Table I with and
without the paper's numbers, the README's scales; Wilson, Fisher and bootstrap on known values."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from harness.report.stats import BOOT_N, boot_interval, boot_medians, fisher_p, wilson
from tests.harness.report._helpers import Q, report, wilson_by_hand, write_log


@pytest.mark.slow  # the whole report, end to end
def test_statistics_exact(tmp_path, known, capsys):
    rc, out = report(tmp_path, known)
    assert rc == 0
    cap = capsys.readouterr()
    assert "read 4 trial logs" in cap.out and "skipped 0" in cap.out
    # bit_star seed 0 is logged twice: counted twice, with one warning naming both files
    dup = (
        f"warning: s2d bit_star seed 0: 2 queries logged in more than one file, all counted: "
        f"{known / 'a' / 'bit0' / 'trials.mcap'}, {known / 'b' / 'bit0' / 'trials.mcap'}"
    )
    assert cap.err.strip().splitlines() == [dup]
    readme = (out / "README.md").read_text()
    assert "## Warnings" in readme and dup.removeprefix("warning: ") in readme
    res = pd.read_csv(out / "results.csv", keep_default_na=False, na_values=[""])
    assert list(zip(res["split"], res["planner"])) == [
        ("seen", "mpnet_nr"),
        ("seen", "bit_star"),
        ("unseen", "mpnet_nr"),
    ]
    nr = res.iloc[0]
    assert (nr["env"], nr["queries"], nr["seeds"], nr["successes"]) == ("s2d", 6, 2, 4)
    assert nr["success_mean"] == pytest.approx(0.625)  # seeds: 3/4 and 1/2
    assert nr["success_std"] == pytest.approx(0.25 / math.sqrt(2))  # ddof=1 over 2 seeds
    assert nr["time_mean_s"] == pytest.approx(0.25)  # successes 0.1 .. 0.4
    assert nr["time_std_s"] == pytest.approx(np.std([0.1, 0.2, 0.3, 0.4], ddof=1))
    assert nr["time_median_s"] == pytest.approx(0.25)
    assert nr["time_p90_s"] == pytest.approx(0.37)
    assert nr["cost_mean"] == pytest.approx(25.0)
    assert nr["collision_checks_median"] == pytest.approx(25.0)
    assert nr["pnet_calls_median"] == pytest.approx(4.0)  # over all 6 queries
    assert nr["replans_mean"] == pytest.approx(5 / 6)
    assert nr["fallback_rate"] == pytest.approx(1 / 6)
    assert nr["failures"] == "no_solution: 1; timeout: 1"
    bit = res.iloc[1]  # one seed, two files
    assert (bit["queries"], bit["seeds"], bit["success_mean"], bit["success_std"]) == (4, 1, 1.0, 0.0)
    assert bit["time_mean_s"] == pytest.approx(2.5) and bit["cost_mean"] == pytest.approx(13.0)
    assert math.isnan(bit["pnet_calls_median"]) and math.isnan(bit["fallback_rate"])
    un = res.iloc[2]
    assert (un["queries"], un["seeds"], un["success_std"], un["time_std_s"]) == (1, 1, 0.0, 0.0)

    # logs without reference_cost, ablations or time-to-equal-quality runs: blanks, no crash
    assert nr["success_rate"] == pytest.approx(4 / 6)
    assert (nr["success_ci_low"], nr["success_ci_high"]) == pytest.approx(wilson_by_hand(4, 6))
    assert nr["time_median_ci_low"] <= nr["time_median_s"] <= nr["time_median_ci_high"]
    assert nr["quality_n"] == 0 and math.isnan(nr["quality_median"]) and math.isnan(nr["quality_p90"])
    # NR seed 0 costs 10, 20 against bit_star seed 0's 12, 14 (NR seed 1 has no BIT* pair)
    assert nr["cost_over_bit_star_n"] == 2
    assert nr["cost_over_bit_star_median"] == pytest.approx((10 / 12 + 20 / 14) / 2)
    assert bit["cost_over_bit_star_n"] == 0 and math.isnan(bit["cost_over_bit_star_median"])
    assert (bit["comparator"], bit["success_diff_significant"]) == ("mpnet_nr", False)
    assert bit["success_p_vs"] == pytest.approx(0.4666667)  # Fisher: 4/4 against 4/6
    assert bit["time_diff_significant"] and bit["time_ratio_vs"] == pytest.approx(10.0)
    assert isinstance(nr["comparator"], float) and math.isnan(nr["comparator"])  # NR: no comparator
    assert (out / "quality.csv").exists() and not (out / "ablations.md").exists()
    assert not (out / "equal_quality.md").exists()
    assert "`ablations.*`: not written" in readme and "`equal_quality.*`: not written" in readme

    t1 = pd.read_csv(out / "table1.csv")
    assert list(t1["split"]) == ["seen", "unseen"] and set(t1["source"]) == {"ours"}
    row = t1.iloc[0]
    assert row["mpnet_nr_time_mean_s"] == pytest.approx(0.25)
    assert row["bit_star_over_mpnet_nr"] == pytest.approx(10.0)
    assert math.isnan(row["mpnet_hr_time_mean_s"]) and math.isnan(t1.iloc[1]["bit_star_over_mpnet_nr"])
    md = (out / "table1.md").read_text()
    assert "| Simple 2D | seen | 0.250 ± 0.129 |  |  | 2.50 ± 0.58 | 10.0 |" in md
    assert "The clock: MPNet's planning loop and RRT-Connect (compiled) call the collision kernels" in md
    # the checks beside the times: NR's solved queries took 10, 20, 30, 40 checks, BIT*'s none logged
    assert "## Collision checks a solved query" in md and "| Simple 2D | seen | 25.0 |" in md
    sc = (out / "success_cost.md").read_text()
    # pooled 4/6 = 66.7% with its Wilson interval [30.0, 90.3]
    assert "| Simple 2D | seen | MPNet (NR) | 62.5 ± 17.7 | 66.7 [30.0, 90.3] | 25.0 | 6 | 2 |" in sc
    assert "ddof=1" in (out / "README.md").read_text()


@pytest.mark.slow  # the whole report, end to end
def test_only_some_planners_blank_cells_and_paper(tmp_path, capsys):
    logs = tmp_path / "logs"
    write_log(logs / "b", "c2d", "bit_star", 0, [Q("unseen", "100", 0, True, 0.002)])
    write_log(logs / "r", "c2d", "rrt_connect", 0, [Q("unseen", "100", 0, True, 0.001)])
    write_log(logs / "i", "c2d", "informed_rrt_star", 0, [Q("unseen", "100", 0, False, 10.0)])
    rc, out = report(tmp_path, logs)
    assert rc == 0
    assert (
        "| Complex 2D | unseen | Informed-RRT* | 0.0 ± 0.0 | 0.0 [0.0, 79.3] |  | 1 | 1 |"
        in (out / "success_cost.md").read_text()
    )
    md = (out / "table1.md").read_text()
    # the paper's layout first (its four planners, the ratio), then the other planners;
    # a planner that ran and solved nothing reads "— (0/N)", one not run is blank
    head = "| Env | Split | MPNet (NR) | MPNet (HR) | Informed-RRT* | BIT* | BIT*/MPNet (NR) | RRT-Connect |"
    assert head in md
    assert "| Complex 2D | unseen |  |  | — (0/1) | 0.00200 ± 0.00000 |  | 0.00100 ± 0.00000 |" in md
    assert "— (0/N)" in md and "blank: the planner was not run" in md
    assert "arXiv:1806.05767" in md and "paper" not in md.split("\n\n")[1]
    assert list(pd.read_csv(out / "table1.csv").columns) == [
        "env",
        "split",
        "source",
        "mpnet_nr_time_mean_s",
        "mpnet_nr_time_std_s",
        "mpnet_hr_time_mean_s",
        "mpnet_hr_time_std_s",
        "informed_rrt_star_time_mean_s",
        "informed_rrt_star_time_std_s",
        "bit_star_time_mean_s",
        "bit_star_time_std_s",
        "bit_star_over_mpnet_nr",
        "rrt_connect_time_mean_s",
        "rrt_connect_time_std_s",
    ]
    assert "--- (0/1)" in (out / "table1.tex").read_text()

    rc, out = report(tmp_path, logs, paper=True)
    assert rc == 0
    md = (out / "table1.md").read_text()
    assert "| Env | Split | Source |" in md
    assert "|  |  | paper | 0.18 ± 0.27 | 0.68 ± 0.41 | 6.31 ± 0.85 | 4.12 ± 1.99 | 22.9 |  |" in md
    assert "Python implementations" in md
    tex = (out / "table1.tex").read_text()
    for cmd in (r"\toprule", r"\midrule", r"\bottomrule", r"$\pm$", "arXiv:1806.05767"):
        assert cmd in tex
    t1 = pd.read_csv(out / "table1.csv")
    assert list(t1["source"]) == ["ours", "paper"]
    assert t1.iloc[1]["bit_star_time_mean_s"] == pytest.approx(4.12)
    assert (out / "success_cost.tex").read_text().count(r"\bottomrule") == 1


@pytest.mark.slow  # the whole report, end to end
def test_paper_numbers_as_printed(tmp_path):
    """--paper shows the paper's numbers exactly as harness/report/paper_table1.csv gives them."""
    logs = tmp_path / "logs"
    write_log(logs / "nr", "rigid", "mpnet_nr", 0, [Q("seen", "0", 0, True, 0.5)])
    write_log(logs / "s", "s2d", "mpnet_nr", 0, [Q("seen", "0", 0, True, 0.5)])
    rc, out = report(tmp_path, logs, paper=True)
    assert rc == 0
    md = (out / "table1.md").read_text()
    assert "|  |  | paper | 0.32 ± 0.28 | 1.92 ± 1.30 | 30.25 ± 27.59 | 11.10 ± 5.59 | 34.7 |" in md
    assert "|  |  | paper | 0.11 ± 0.037 | 0.19 ± 0.14 | 5.36 ± 0.34 | 2.71 ± 1.72 | 24.6 |" in md
    assert "ratio of the paper's mean times, computed here" in md
    tex = (out / "table1.tex").read_text()
    assert r"30.25 $\pm$ 27.59 & 11.10 $\pm$ 5.59 & 34.7" in tex


@pytest.mark.slow  # the whole report, end to end
def test_readme_scales_and_no_warnings(tmp_path, capsys):
    logs = tmp_path / "logs"
    quick = (
        "budget_s: 10.0\nscale:\n  name: quick\n  test:\n    seen: {workspaces: 20, queries: 10}\n"
        "    unseen: {workspaces: 10, queries: 20}\n  train: {workspaces: 100, paths: 40}\n"
        "  model: {pnet_hidden: [512, 256, 128, 64]}\nplanner:\n  name: bit_star\n"
    )
    write_log(logs / "q", "s2d", "bit_star", 0, [Q("seen", "0", 0, True, 1.0)], config=quick)
    write_log(
        logs / "p",
        "s2d",
        "mpnet_nr",
        0,
        [Q("seen", "0", 0, True, 1.0)],
        config="budget_s: 10.0\nscale:\n  name: paper\nplanner:\n  name: mpnet_nr\n",
    )
    write_log(
        logs / "o",
        "s2d",
        "rrt_star",
        0,
        [Q("seen", "0", 0, True, 1.0)],
        config="budget_s: 10.0\nscale:\n  name: mine\nplanner:\n  name: rrt_star\n",
    )
    rc, out = report(tmp_path, logs)
    assert rc == 0 and capsys.readouterr().err == ""
    readme = (out / "README.md").read_text()
    assert "## Warnings" in readme and readme.split("## Warnings")[1].split("##")[0].strip().endswith("none")
    assert (
        "- Our `quick` scale trains smaller networks on 100 workspaces × 40 expert paths and tests on "
        "200 seen + 200 unseen queries per seed; the paper: 100 × 4000 paths; 100 × 200 seen, "
        "10 × 2000 unseen."
    ) in readme
    assert "- Scale `paper`: the paper's sizes." in readme
    judged = "fine re-check (s2d: every 0.01 along the path, a point against the boxes, exact)"
    assert judged in " ".join(readme.split())
    assert "- Scale `mine`: smaller than the paper's." in readme


def test_wilson_fisher_bootstrap_known_values():
    assert wilson(3, 4) == pytest.approx(wilson_by_hand(3, 4))
    assert wilson(0, 1) == pytest.approx((0.0, wilson_by_hand(0, 1)[1]))
    assert all(math.isnan(x) for x in wilson(0, 0))
    # hypergeometric by hand: margins 5 / 5 of 10, P(x) = C(5, x)^2 / 252; |x - 2.5| >= 1.5
    assert fisher_p(4, 5, 1, 5) == pytest.approx(52 / 252)
    assert fisher_p(3, 4, 1, 4) == pytest.approx(34 / 70)
    assert math.isnan(fisher_p(1, 1, 0, 0))
    # the order-statistic bootstrap has the distribution of medians of resamples drawn with replacement
    brute = np.random.default_rng(1)
    for x in ([1.0, 2.0, 3.0, 4.0, 10.0], [1.0, 2.0, 3.0, 4.0, 5.0, 7.0], [0.5, 0.5, 2.0, np.inf]):
        fast = boot_medians(x, ("test", len(x)))
        slow = np.median(brute.choice(x, (BOOT_N, len(x))), axis=1)
        assert len(fast) == BOOT_N and set(fast) <= set(slow) | {np.inf}
        for v in sorted(set(slow)):
            assert np.mean(fast == v) == pytest.approx(np.mean(slow == v), abs=0.02)
        assert np.array_equal(fast, boot_medians(x, ("test", len(x))))  # seeded: reproducible
    assert boot_interval(boot_medians([0.5] * 5, ("c",))) == (0.5, 0.5)
    assert boot_medians([], ("e",)) is None and all(math.isnan(v) for v in boot_interval(None))
    lo, hi = boot_interval(boot_medians([1.0, np.inf, np.inf], ("inf",)))
    assert lo == 1.0 and hi == np.inf
