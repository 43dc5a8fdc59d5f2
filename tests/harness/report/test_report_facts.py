"""What the report says of a run from its facts: planner and env names and order, a recipe's
label, the facts from the run's config, each env's judge, every failure's named status."""

from __future__ import annotations

import pandas as pd
import pytest
import yaml

from harness.report.facts import Facts, planner_facts, run_facts
from harness.report.load import load
from harness.report.names import env_rank
from harness.report.readme import judge_bullet
from tests.harness.report._helpers import Q, planner_config, planner_section, report, write_log


def test_planner_names():
    """Comparators, labels and order follow what each name's config (conf/planner) says it is."""
    names = [
        "bit_star_to_nr",
        "mpnet_hr_random",
        "mpnet_nr_zeros",
        "mpnet_nr_random",
        "rrt_star",
        "bit_star",
        "mpnet_nr",
    ]
    more = ["mpnet_hr", "mpnet_hr_zeros", "mpnet_hr_nodropout", "informed_rrt_star_to_nr_x1.1"]
    facts = Facts({n: run_facts({"planner": n, "config": planner_config(n)}) for n in names + more})
    assert facts.comparator("mpnet_nr") is None and facts.comparator("mpnet_hr") == "mpnet_nr"
    assert facts.comparator("mpnet_nr_zeros") == "mpnet_nr" and facts.comparator("mpnet_hr_zeros") == "mpnet_hr"
    assert facts.comparator("bit_star") == "mpnet_nr"
    assert facts.label("mpnet_hr_nodropout") == "MPNet (HR): nodropout"
    assert facts.label("informed_rrt_star_to_nr_x1.1") == "Informed-RRT* to NR ×1.1"
    assert facts.label("bit_star_to_nr") == "BIT* to NR"
    assert sorted(names, key=facts.rank) == [
        "mpnet_nr",
        "bit_star",
        "rrt_star",
        "mpnet_nr_random",
        "mpnet_nr_zeros",
        "mpnet_hr_random",
        "bit_star_to_nr",
    ]
    # a name alone says nothing: without facts, every one of them is a plain planner
    assert Facts().ablation("mpnet_nr_zeros") is None and Facts().equal_quality("bit_star_to_nr") is None


def test_a_recipe_labelled_planner_is_compared_with_its_own_planner_on_the_envs_recipe():
    """`mpnet_nr [dagger2]` (a label its networks' recipe gave, load.recipe_label) compares with
    mpnet_nr, not with itself (its significance was p = 1 against itself); an HR variant with
    the paper's recipe with the same HR variant on the env's; a --label keeps its own label's base."""
    from harness.report.facts import PlannerFacts

    nr, hrc = PlannerFacts("mpnet_nr"), PlannerFacts("mpnet_hr", "rrtc")
    by = {
        "mpnet_nr": nr,
        "mpnet_nr [dagger2]": PlannerFacts("mpnet_nr", "dagger2"),
        "mpnet_nr_paper [paper_recipe]": PlannerFacts("mpnet_nr", "paper_recipe"),
        "mpnet_nr [pairs_uniform]": nr,
        "mpnet_hr_rrtc": hrc,
        "mpnet_hr_rrtc [paper_recipe]": PlannerFacts("mpnet_hr", "paper_recipe+rrtc"),
        "mpnet_nr_random [first10]": PlannerFacts("mpnet_nr", "random"),
        "mpnet_nr [first10]": nr,
    }
    tags = {n: (n.split(" [")[0], n.split(" [")[1][:-1] if " [" in n else None) for n in by}
    recipes = [n for n in by if " [" in n and "first10" not in n]
    facts = Facts(by, tags, recipes=recipes)
    assert facts.comparator("mpnet_nr [dagger2]") == "mpnet_nr"
    assert facts.comparator("mpnet_nr_paper [paper_recipe]") == "mpnet_nr"
    assert facts.comparator("mpnet_nr [pairs_uniform]") == "mpnet_nr"
    assert facts.comparator("mpnet_hr_rrtc [paper_recipe]") == "mpnet_hr_rrtc"
    assert facts.comparator("mpnet_nr_random [first10]") == "mpnet_nr [first10]"
    assert facts.comparator("mpnet_nr [first10]") is None
    assert (
        Facts({"mpnet_nr [dagger2]": by["mpnet_nr [dagger2]"]}, recipes=["mpnet_nr [dagger2]"]).comparator(
            "mpnet_nr [dagger2]"
        )
        is None
    )  # no run of the env's recipe: nothing to compare with


@pytest.mark.slow  # the whole report, end to end
def test_facts_come_from_the_run_config(tmp_path, capsys):
    """What a planner is comes from its /run config, whatever its name: keys of old configs and of
    configs without `_target_` / `needs_models` give the same facts; no readable config: a plain planner."""

    def facts(conf, **kw):
        return run_facts({"planner": kw.get("name", conf), "config": planner_config(conf, **kw)})

    assert facts("mpnet_nr", name="whatever", proposal="random").ablation == ("mpnet_nr", "random")
    assert facts("mpnet_hr", proposal="straight", dropout=False).ablation == ("mpnet_hr", "straight+nodropout")
    assert facts("mpnet_hr").ablation is None and facts("mpnet_hr").base == "mpnet_hr"
    assert facts("mpnet_hr_rrtc").ablation == ("mpnet_hr", "rrtc")
    assert facts("mpnet_nr_dense").ablation == ("mpnet_nr", "dense")
    assert facts("mpnet_hr_dense").ablation == ("mpnet_hr", "dense")
    assert facts("bit_star_to_nr_x1.1").equal_quality == ("bit_star", "nr", 1.1)
    assert facts("rrt_star", cost_target={"hybrid": True}, cost_factor=1.5).equal_quality == ("rrt_star", "hr", 1.5)
    new_style = {k: v for k, v in planner_section("mpnet_nr_zeros").items() if k != "needs_models"}
    new_style["_target_"] = "mpnet.somewhere.else"
    assert run_facts({"planner": "x", "config": yaml.safe_dump({"planner": new_style})}).ablation == (
        "mpnet_nr",
        "zeros",
    )
    assert facts("bit_star", name="mpnet_nr_random").ablation is None  # the name does not count
    assert run_facts({"planner": "x", "config": "planner: [unclosed"}) is None

    logs = tmp_path / "logs"
    write_log(logs / "nr", "s2d", "mpnet_nr", 0, [Q("seen", "0", i, True, 0.1) for i in range(3)])
    write_log(
        logs / "fancy",
        "s2d",
        "fancy",
        0,
        [Q("seen", "0", i, i > 0, 0.2) for i in range(3)],
        config=planner_config("mpnet_nr", name="fancy", proposal="random"),
    )
    write_log(
        logs / "chase",
        "s2d",
        "chase",
        0,
        [Q("seen", "0", i, True, 0.3, cost=10.0, stats={"target_cost": 10.0, "target_time_s": 0.1}) for i in range(3)],
        config=planner_config("bit_star_to_nr_x1.1", name="chase"),
    )
    write_log(
        logs / "broken",
        "s2d",
        "mpnet_nr_zeros",
        0,
        [Q("seen", "0", 0, True, 0.4)],
        config="budget_s: 10.0\nplanner: [unclosed\n",
    )
    rc, out = report(tmp_path, logs)
    err = capsys.readouterr().err
    assert rc == 0 and "Traceback" not in err
    assert err.strip().splitlines() == [
        f"warning: {logs / 'broken' / 'trials.mcap'}: its /run has no readable "
        "config with a planner section: mpnet_nr_zeros counted as a plain planner"
    ]
    res = pd.read_csv(out / "results.csv")
    assert list(res["planner"]) == ["mpnet_nr", "mpnet_nr_zeros", "fancy"]  # chase: equal_quality.csv
    assert res.set_index("planner").loc["fancy", "comparator"] == "mpnet_nr"
    ab = pd.read_csv(out / "ablations.csv", keep_default_na=False)
    assert list(zip(ab["planner"], ab["base"], ab["variant"])) == [
        ("mpnet_nr", "mpnet_nr", ""),
        ("fancy", "mpnet_nr", "random"),
    ]
    assert "| MPNet (NR): random | a uniformly random valid state" in (out / "ablations.md").read_text()
    assert "fancy" not in pd.read_csv(out / "table1.csv").columns.str.cat()
    assert "mpnet_nr_zeros_time_mean_s" in pd.read_csv(out / "table1.csv").columns  # plain: a column of its own
    eq = pd.read_csv(out / "equal_quality.csv")
    assert list(zip(eq["planner"], eq["algorithm"], eq["factor"], eq["target_planner"], eq["reached"])) == [
        ("chase", "bit_star", 1.1, "mpnet_nr", 3)
    ]
    files, _, _ = load([logs])
    assert planner_facts(files)[0].equal_quality("chase") == ("bit_star", "nr", 1.1)


def test_env_order():
    assert sorted(["zeta", "rigid", "arm7", "s2d", "c3d", "c2d"], key=env_rank) == [
        "s2d",
        "c2d",
        "c3d",
        "rigid",
        "arm7",
        "zeta",
    ]


def test_a_scale_with_env_specific_sizes_names_its_envs():
    """One scale name with two sizes (arm7's quick is its own): each bullet says whose it is."""
    from harness.report.readme import _scale_rows, scale_bullet

    small, big = (10, 60, 10, 5, 10, 5), (100, 40, 100, 2, 10, 20)
    rows = _scale_rows({("quick", small, True): {"arm7"}, ("quick", big, True): {"rigid", "s2d"}})
    assert [r[3] for r in rows] == ["arm7", "s2d, rigid"]
    assert scale_bullet(*rows[0]).startswith("Our `quick` scale for arm7 trains smaller networks on 10 workspaces")
    assert _scale_rows({("quick", big, True): {"s2d", "c2d"}})[0][3] == ""  # one size: no envs named
    assert scale_bullet(*_scale_rows({("quick", big, True): {"s2d"}})[0]).startswith("Our `quick` scale trains")


def test_every_failure_the_harness_logs_has_a_named_status():
    """A failure reason the harness writes maps to a status Planner Arena names (never
    "Unknown status"): a cost-target query with no target is "not run"."""
    import pandas as pd

    from harness.report.arena import OMPL_STATUS, ST_UNKNOWN, ompl_status

    failures = ["timeout", "invalid_query", "error", "no_solution", "recheck_collision", "no_target", None]
    success = [False] * 6 + [True]
    st = ompl_status(pd.Series(success), pd.Series(failures))
    assert ST_UNKNOWN not in st
    assert [OMPL_STATUS[s] for s in st] == [
        "Timeout",
        "Invalid start",
        "Crash",
        "Abort",
        "Invalid solution (failed the re-check)",
        "Not run (no target: the planner it chases failed)",
        "Exact solution",
    ]


def test_judge_bullet_says_how_each_env_was_judged():
    """The README said "every 0.01 along the path, exact boxes" for every env, the arm's too
    (judged by pybullet at 0.002 rad): each env now gets its own step, as its runs logged it,
    and its checker's geometry."""
    text = judge_bullet({"panda_mbm": {0.002}, "s2d": {None}, "rigid": {0.01, 0.005}, "mystery": {None}})
    how = text.split("(", 1)[1].rsplit(")", 1)[0]
    assert how.split("; ") == [
        "s2d: every 0.01 along the path, a point against the boxes, exact",
        "rigid: every 0.005 or 0.01 along the path, the rectangle against the boxes, exact (separating axes)",
        "panda_mbm: every 0.002 rad along the path, pybullet on the arm model's collision meshes, no margin",
        "mystery: as its runs' config says",
    ]
    assert "exact boxes" not in judge_bullet({"arm7": {0.002}})


@pytest.mark.slow  # two whole reports
def test_generated_and_file_runs_of_a_planner_are_not_labelled_apart(tmp_path):
    """A planner run on the generated split and on a problem file (the same settings but
    `problems`) keeps its plain name: the two never share a split, so nothing pools them. Before,
    a recipe screen's tables named them `mpnet_nr [problems=null]` and `mpnet_nr [problems=298f2524]`.
    Two problem files are still two variants."""
    logs = tmp_path / "logs"
    settings = {"seed": 0, "budget_s": 10.0, "planner.name": "rrt_connect", "problems": None}
    gen = [Q("seen", "0", i, True, 1.0) for i in range(2)]
    on_file = [Q("file", "0", i, True, 1.0) for i in range(2)]
    write_log(logs / "gen", "s2d", "rrt_connect", 0, gen, settings=settings)
    write_log(logs / "a", "s2d", "rrt_connect", 0, on_file, settings={**settings, "problems": "sha256:" + "a" * 64})
    rc, out = report(tmp_path, logs)
    assert rc == 0
    assert set(pd.read_csv(out / "results.csv")["planner"]) == {"rrt_connect"}
    write_log(logs / "b", "s2d", "rrt_connect", 0, on_file, settings={**settings, "problems": "sha256:" + "b" * 64})
    rc, out = report(tmp_path, logs)
    assert rc == 0
    assert set(pd.read_csv(out / "results.csv")["planner"]) == {
        "rrt_connect",
        "rrt_connect [problems=aaaaaaaa]",
        "rrt_connect [problems=bbbbbbbb]",
    }
