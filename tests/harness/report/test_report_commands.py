"""The report's commands (harness.report.commands): folded from the runs' logged overrides,
they run exactly the logged runs again, no more and no fewer."""

from __future__ import annotations

import itertools
import shlex

from hypothesis import given
from hypothesis import strategies as st

from harness.report.commands import SWEPT, sweep_commands


def _runs_of(command: str) -> set[tuple]:
    """The jobs a `python -m harness [-m] ...` line runs: (sorted other overrides, env, planner, seed)."""
    args = shlex.split(command)
    assert args[:3] == ["python", "-m", "harness"]
    args = [a for a in args[3:] if a != "-m"]
    swept = {k: [None] for k in SWEPT}
    rest = []
    for a in args:
        key, _, value = a.partition("=")
        if key in swept:
            swept[key] = value.split(",")
        else:
            rest.append(a)
    return {(tuple(sorted(rest)), *combo) for combo in itertools.product(*swept.values())}


def test_a_grid_is_one_multirun_command():
    runs = [
        ["+env=" + e, "+planner=" + p, f"seed={s}", "scale=stats", "cache_dir=/a b"]
        for e in ("s2d", "c2d")
        for p in ("mpnet_nr", "bit_star")
        for s in (10, 2)
    ]
    assert sweep_commands(runs) == [
        "python -m harness -m +env=c2d,s2d +planner=bit_star,mpnet_nr seed=2,10 scale=stats 'cache_dir=/a b'"
    ]


def test_one_run_is_one_plain_command_and_unlogged_runs_give_none():
    assert sweep_commands([["+env=s2d", "+planner=bit_star", "budget_s=2"]]) == [
        "python -m harness +env=s2d +planner=bit_star budget_s=2"
    ]
    assert sweep_commands([["+env=s2d", "+planner=bit_star"], None]) is None
    assert sweep_commands([]) is None


_ENVS, _PLANNERS, _SEEDS = ["s2d", "c2d", "rigid"], ["bit_star", "mpnet_nr", "mpnet_hr"], ["0", "1", "17"]


@given(
    st.sets(
        st.tuples(
            st.sampled_from(_ENVS),
            st.sampled_from(_PLANNERS),
            st.sampled_from(_SEEDS),
            st.sampled_from([(), ("scale=tiny",), ("scale=tiny", "budget_s=1")]),
        ),
        min_size=1,
        max_size=20,
    )
)
def test_the_commands_run_exactly_the_logged_runs(runs):
    logged = [[f"+env={e}", f"+planner={p}", f"seed={s}", *rest] for e, p, s, rest in runs]
    commands = sweep_commands(logged)
    jobs = [job for c in commands for job in _runs_of(c)]
    assert len(jobs) == len(set(jobs)) == len(runs)  # no job twice, none extra
    assert set(jobs) == {(tuple(sorted(rest)), e, p, s) for e, p, s, rest in runs}


def _run(env, planner, seed, *rest):
    overrides = [f"+env={env}", f"+planner={planner}", f"seed={seed}", *rest]
    return {"env": env, "planner": planner, "seed": seed, "overrides": overrides}


def test_a_report_names_what_its_runs_lack_and_the_command_that_makes_it():
    from harness.report.commands import missing_runs

    hr = [_run("rigid", "mpnet_hr", s, "scale=quick") for s in (0, 1)]
    (line,) = missing_runs(hr)  # no MPNet-NR: its ablations are not asked for
    assert line.startswith("rigid: no runs of Table I's MPNet (NR), Informed-RRT*, BIT*")
    cmd = line.split("to make them: ")[1]
    assert _runs_of(cmd) == {
        (("scale=quick",), "rigid", p, s) for p in ("mpnet_nr", "informed_rrt_star", "bit_star") for s in ("0", "1")
    }
    full = [_run("s2d", p, 0) for p in ("mpnet_nr", "mpnet_hr", "informed_rrt_star", "bit_star")]
    (line,) = missing_runs(full)
    assert "ablations" in line and _runs_of(line.split("to make them: ")[1]) == {
        ((), "s2d", p, "0")
        for p in ("mpnet_nr_random", "mpnet_nr_random_any", "mpnet_nr_straight", "mpnet_nr_zeros", "mpnet_nr_nodropout")
    }
    ablations = [_run("s2d", p, 0) for p in ("mpnet_nr_random", "mpnet_nr_random_any", "mpnet_nr_straight")]
    ablations += [_run("s2d", p, 0) for p in ("mpnet_nr_zeros", "mpnet_nr_nodropout")]
    assert missing_runs(full + ablations) == []
    assert missing_runs([*hr[:1], {**hr[1], "overrides": None}]) == []  # a run without overrides: say nothing
