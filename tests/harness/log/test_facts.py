"""A run's facts (harness/log/facts.py): logged once in /run from the resolved config, read by the
report instead of the config; older logs get the same facts from their config text."""

from __future__ import annotations

import pytest
from omegaconf import OmegaConf

from harness.core.cli import choices
from harness.log.facts import FACTS_FORMAT, facts_from_config, legacy_facts, run_facts


@pytest.mark.parametrize("planner", choices("planner"))
@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_logged_facts_equal_what_an_old_logs_config_text_gives(planner, compose_config):
    cfg = compose_config(["+env=panda_mbm" if "dense" in planner else "+env=s2d", f"+planner={planner}"])
    container = OmegaConf.to_container(cfg, resolve=True)
    logged = facts_from_config(container, workspace_dim=2, robot="point")
    old = legacy_facts({"config": OmegaConf.to_yaml(cfg, resolve=True)})
    assert {**logged, "workspace_dim": None, "robot": None} == old
    assert run_facts({"facts": logged, "config": "not: [yaml"}) == logged  # logged facts win
    assert logged["format"] == FACTS_FORMAT and logged["budget_s"] == 10.0
    p = logged["planner"]
    if planner.startswith("mpnet_"):
        assert p["base"] == ("mpnet_hr" if planner.startswith("mpnet_hr") else "mpnet_nr")
        assert (p["variant"] is None) == (planner in ("mpnet_nr", "mpnet_hr"))
    elif "_to_nr" in planner:
        assert p["target"] == "nr" and p["algorithm"] == planner.split("_to_nr")[0]
        assert p["factor"] == (float(planner.split("_x")[1]) if "_x" in planner else 1.0)
    elif cfg.planner.get("algorithm") is not None:  # OMPL's planners: a classical run of their algorithm
        assert p["algorithm"] == planner and p["base"] is None
    else:  # a planner without an OMPL algorithm (rrt_connect_compiled): a plain planner, by its name
        assert p["algorithm"] is None and p["base"] is None and cfg.planner.name == planner


def test_facts_of_an_unreadable_config_are_empty():
    facts = legacy_facts({"config": "planner: [unclosed"})
    assert facts["planner"] is None and facts["budget_s"] is None and facts["scale"] is None
    assert legacy_facts({})["planner"] is None


def test_the_report_parses_no_config(repo):
    """Issue 27: the report reads a run's facts, never its config YAML or a regex over it (its
    own tables, harness/report/*.yaml, are read by own_data.py alone)."""
    for path in sorted((repo / "harness" / "report").glob("*.py")):
        if path.name == "own_data.py":
            continue
        text = path.read_text()
        assert "safe_load" not in text and "yaml.load" not in text, path.name
        assert "re.search" not in text or "config" not in text.split("re.search", 1)[1][:80], path.name


OLD_LOGS = ("s2d_mpnet_nr", "s2d_bit_star_to_nr_x1.1")


@pytest.mark.parametrize("name", OLD_LOGS)
def test_a_log_written_before_facts_still_reads(name, repo):
    """tests/data/old_logs: tiny runs logged by revision af39b8a, before /run carried `facts`."""
    from harness.report.facts import run_facts as planner_facts
    from harness.report.load import read_trials

    tf, warning = read_trials(repo / "tests" / "data" / "old_logs" / name / "trials.mcap")
    assert tf is not None and warning is None and "facts" not in tf.run
    facts = run_facts(tf.run)
    assert facts["budget_s"] == 10.0 and (facts["train_workspaces"], facts["train_paths"]) == (2, 10)
    assert facts["scale"]["name"] == "tiny" and facts["planner_config"]["name"] == tf.run["planner"]
    pf = planner_facts(tf.run)
    if name.endswith("mpnet_nr"):
        assert (pf.base, pf.variant, pf.equal_quality) == ("mpnet_nr", None, None)
    else:
        assert pf.equal_quality == ("bit_star", "nr", 1.1)
