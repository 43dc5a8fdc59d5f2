"""The report's quality ablations and time-to-equal-quality table, from known logs."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from harness.report.stats import BOOT_N
from tests.harness.report._helpers import Q, eq_config, report, wilson_by_hand, write_log


@pytest.fixture()
def quality_logs(tmp_path):
    """s2d seen: MPNet (NR), (HR), Informed-RRT*, BIT* with reference costs, two ablations, and
    two time-to-equal-quality runs; rigid: one run with a planned reference."""
    logs = tmp_path / "qlogs"

    def ref(r):
        return {"reference_cost": r}

    write_log(
        logs / "nr",
        "s2d",
        "mpnet_nr",
        0,
        [
            Q("seen", "0", 0, True, 0.1, cost=11.0, stats=ref(10.0)),  # quality 1.1
            Q("seen", "0", 1, True, 0.2, cost=26.0, stats=ref(20.0)),  # 1.3
            Q("seen", "0", 2, True, 0.3, cost=48.0, stats=ref(30.0)),  # 1.6
            Q("seen", "0", 3, False, 9.0, stats=ref(40.0)),
            Q("seen", "0", 4, True, 0.2, cost=5.0),
        ],
    )  # no reference: not in quality
    write_log(
        logs / "bit0",
        "s2d",
        "bit_star",
        0,
        [
            Q("seen", "0", 0, True, 0.1, cost=10.0),
            Q("seen", "0", 1, True, 0.2, cost=20.0),
            Q("seen", "0", 2, False, 9.0),
            Q("seen", "0", 3, True, 0.3, cost=5.0),
            Q("seen", "0", 4, False, 9.0),
        ],
    )
    write_log(logs / "bit1", "s2d", "bit_star", 1, [Q("seen", "0", 0, True, 0.2, cost=100.0)])  # no NR seed 1
    write_log(logs / "irrt", "s2d", "informed_rrt_star", 0, [Q("seen", "0", i, True, 5.0 + i) for i in range(5)])
    write_log(logs / "hr", "s2d", "mpnet_hr", 0, [Q("seen", "0", i, True, 0.5) for i in range(5)])
    write_log(logs / "hr_zeros", "s2d", "mpnet_hr_zeros", 0, [Q("seen", "0", i, True, 0.5) for i in range(5)])
    write_log(
        logs / "nr_random",
        "s2d",
        "mpnet_nr_random",
        0,
        [Q("seen", "0", 0, True, 1.0, cost=10.0, stats=ref(10.0))]
        + [Q("seen", "0", i, False, 9.0) for i in range(1, 5)],
    )

    def target(cost, t):
        return {"target_planner": "mpnet_nr", "target_cost": cost, "target_time_s": t}

    no_target = Q("seen", "0", 3, False, 0.0, failure="no_target", stats=target(None, 0.5))
    write_log(
        logs / "to_nr",
        "s2d",
        "bit_star_to_nr",
        0,
        [  # factor from the config: 1.0
            Q("seen", "0", 0, True, 1.0, cost=9.9, stats=target(10.0, 0.1)),
            Q("seen", "0", 1, True, 2.0, cost=20.0, stats=target(20.0, 0.3)),
            Q("seen", "0", 2, False, 10.0, stats=target(30.0, 0.2)),
            no_target,
        ],
        config=eq_config("bit_star_to_nr"),
    )
    write_log(
        logs / "to_nr_x",
        "s2d",
        "bit_star_to_nr_x1.1",
        0,
        [  # factor from the config: 1.1
            Q("seen", "0", 0, True, 0.5, cost=10.9, stats=target(10.0, 0.1)),
            Q("seen", "0", 1, True, 9.0, cost=25.0, stats=target(20.0, 0.3)),  # above 1.1 x 20: a miss
            Q("seen", "0", 2, False, 10.0, stats=target(30.0, 0.2)),
            no_target,
        ],
        config=eq_config("bit_star_to_nr_x1.1", 1.1),
    )
    rigid_cfg = (
        "budget_s: 10.0\nenv:\n  name: rigid\n  expert: {iterations: 2000}\n  reference: {bit_star_s: 1.0}\n"
        "planner:\n  name: bit_star\n"
    )
    write_log(
        logs / "rigid",
        "rigid",
        "bit_star",
        0,
        [Q("seen", "0", 0, True, 0.1, cost=9.0, stats=ref(10.0))],
        config=rigid_cfg,
    )
    return logs


@pytest.mark.slow  # the whole report, end to end
def test_quality_ablations_equal_quality(tmp_path, quality_logs, capsys):
    rc, out = report(tmp_path, quality_logs)
    assert rc == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        (
            "warning: bit_star_to_nr_x1.1: 1 of its logged successes have a path cost above factor x "
            "target cost: counted as not reaching the target"
        )
    ]
    res = pd.read_csv(out / "results.csv")
    s2d = res[res["env"] == "s2d"].set_index("planner")
    # the time-to-equal-quality runs are not rows of results.csv; the ablations are, after the others
    assert list(s2d.index) == [
        "mpnet_nr",
        "mpnet_hr",
        "informed_rrt_star",
        "bit_star",
        "mpnet_nr_random",
        "mpnet_hr_zeros",
    ]
    nr, bit, rnd, hrz = s2d.loc["mpnet_nr"], s2d.loc["bit_star"], s2d.loc["mpnet_nr_random"], s2d.loc["mpnet_hr_zeros"]
    for r in s2d.itertuples():  # every success rate has its interval
        assert (r.success_ci_low, r.success_ci_high) == pytest.approx(wilson_by_hand(r.successes, r.queries))
    assert (nr["successes"], nr["queries"]) == (4, 5) and (bit["successes"], bit["queries"]) == (4, 6)
    assert (nr["quality_n"], nr["quality_median"], nr["quality_p90"]) == (
        3,
        pytest.approx(1.3),
        pytest.approx(1.3 + 0.8 * 0.3),
    )
    assert (nr["cost_over_bit_star_n"], nr["cost_over_bit_star_median"]) == (2, pytest.approx(1.2))
    assert (rnd["quality_n"], rnd["quality_median"], rnd["cost_over_bit_star_median"]) == (1, 1.0, 1.0)
    assert bit["quality_n"] == 0 and math.isnan(bit["cost_over_bit_star_median"])
    assert res[res["env"] == "rigid"].iloc[0]["quality_median"] == pytest.approx(0.9)
    # significance against the comparator
    assert rnd["comparator"] == "mpnet_nr" and rnd["success_p_vs"] == pytest.approx(52 / 252)
    assert not rnd["success_diff_significant"] and rnd["time_diff_significant"]
    assert rnd["time_ratio_vs"] == pytest.approx(5.0) and rnd["time_ratio_vs_ci_low"] > 1
    assert hrz["comparator"] == "mpnet_hr" and (
        hrz["time_ratio_vs"],
        hrz["time_ratio_vs_ci_low"],
        hrz["time_ratio_vs_ci_high"],
    ) == (1.0, 1.0, 1.0)
    assert not hrz["time_diff_significant"] and (hrz["time_median_ci_low"], hrz["time_median_ci_high"]) == (0.5, 0.5)
    assert not bit["time_diff_significant"] and bit["time_ratio_vs_ci_low"] < 1 < bit["time_ratio_vs_ci_high"]
    assert s2d.loc["informed_rrt_star", "time_diff_significant"] and s2d.loc["mpnet_hr", "comparator"] == "mpnet_nr"

    md = (out / "table1.md").read_text()  # BIT*'s median time and the ratio: not significant
    assert "| Simple 2D | seen | 0.200 ± 0.082 | 0.500 ± 0.000 | 7.00 ± 1.58 | ≈ 0.200 ± 0.082 | ≈ 1.00 |" in md
    assert "random" not in md and "to NR" not in md and "≈ before a time" in md
    assert r"$\approx$ 1.00" in (out / "table1.tex").read_text()
    assert set(pd.read_csv(out / "success_cost.csv")["planner"]) == {
        "mpnet_nr",
        "mpnet_hr",
        "informed_rrt_star",
        "bit_star",
    }
    sc = (out / "success_cost.md").read_text()
    assert "|  |  | Informed-RRT* | ≈ 100.0 ± 0.0 | 100.0 [56.6, 100.0] | 50.0 | 5 | 1 |" in sc
    assert "Fisher exact" in sc

    q = pd.read_csv(out / "quality.csv")
    assert len(q) == len(res)
    qmd = (out / "quality.md").read_text()
    assert "| Simple 2D | seen | MPNet (NR) | 1.30 | 1.54 | 3 | 1.20 | 2 |" in qmd
    assert "exact shortest path" in qmd and "2000 iterations" in qmd and "1.0 s" in qmd

    ab = pd.read_csv(out / "ablations.csv")
    assert list(ab["planner"]) == ["mpnet_nr", "mpnet_nr_random", "mpnet_hr", "mpnet_hr_zeros"]
    assert list(ab["base"]) == ["mpnet_nr", "mpnet_nr", "mpnet_hr", "mpnet_hr"]
    assert ab["success_p_vs"].isna().tolist() == [True, False, True, False]  # bases are not compared
    amd = (out / "ablations.md").read_text()
    lo, hi = wilson_by_hand(1, 5)
    assert (
        f"| MPNet (NR): random | a uniformly random valid state instead of Pnet's proposal | "
        f"≈ 20.0 [{100 * lo:.1f}, {100 * hi:.1f}] | 1.00 [1.00, 1.00] | 5.00 [" in amd
    )
    assert (
        "| MPNet (HR): zeros | Pnet given a zero workspace code | ≈ 100.0 [56.6, 100.0] | "
        "≈ 0.500 [0.500, 0.500] | 1.00 [1.00, 1.00] |" in amd
    )

    eq = pd.read_csv(out / "equal_quality.csv")
    assert list(zip(eq["algorithm"], eq["factor"])) == [("bit_star", 1.0), ("bit_star", 1.1)]
    one, x11 = eq.iloc[0], eq.iloc[1]
    assert (one["queries"], one["no_target"], one["targeted"], one["reached"]) == (4, 1, 3, 2)
    assert (one["reach_ci_low"], one["reach_ci_high"]) == pytest.approx(wilson_by_hand(2, 3))
    assert (one["time_to_reach_median_s"], one["censored"], one["time_reached_median_s"]) == (2.0, False, 1.5)
    assert (one["target_time_median_s"], one["time_ratio"]) == (pytest.approx(0.2), pytest.approx(10.0))
    assert (x11["targeted"], x11["reached"], x11["censored"], x11["budget_s"]) == (3, 1, True, 10.0)
    assert math.isinf(x11["time_to_reach_median_s"]) and math.isinf(x11["time_ratio"])
    assert x11["time_reached_median_s"] == 0.5
    emd = (out / "equal_quality.md").read_text()
    assert "| Simple 2D | seen | BIT* | cost ≤ 1 × MPNet (NR)'s | 1 | 3 | 66.7 [20.8, 93.9] | 2.00 [" in emd
    assert "|  |  | BIT* | cost ≤ 1.1 × MPNet (NR)'s | 1 | 3 | 33.3 [6.1, 79.2] | > budget (10.0 s) [" in emd
    assert "| > 50.0 |" in emd
    readme = (out / "README.md").read_text()
    for name in (
        "quality.md",
        "ablations.md",
        "equal_quality.md",
        "Wilson",
        "Fisher",
        f"{BOOT_N} resamples",
        "rigid (Rigid body): path cost = OMPL's SE(2) metric",
    ):
        assert name in readme

    # a later report without those runs removes their tables
    rc, out = report(tmp_path, quality_logs / "bit0")
    assert rc == 0 and not any(
        (out / f"{n}.{e}").exists() for n in ("quality", "ablations", "equal_quality") for e in ("md", "csv")
    )
