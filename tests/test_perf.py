"""`python -m harness.perf` end to end at its tiny settings."""

import pandas as pd
import pytest


@pytest.mark.slow
def test_perf_writes_every_section(run_cli, tmp_path, sweeps_cache):
    out = tmp_path / "reports"
    run_cli(
        "harness.perf",
        "perf=tiny",
        "perf.envs=[s2d]",
        f"out={out}",
        f"cache_dir={sweeps_cache}",  # the tiny s2d networks the other tests train too
        f"hydra.run.dir={tmp_path / 'run'}",
        timeout=900,
    )
    md = (out / "perf.md").read_text()
    for title in (
        "## Planners on the same queries",
        "## Where MPNet's time goes",
        "## Harness overhead and memory",
        "## How cost grows with dimension",
        "## How cost grows with the number of obstacles",
        "## Batched planning: throughput and latency",
        "## Networks against their floor",
        "## Collision checking throughput",
        "## The price of a check: compiled, and through OMPL's callbacks into Python",
        "## Data generation",
        "## Training throughput",
        "## GPU",
    ):
        assert title in md
    assert (out / "figures" / "perf_growth.png").stat().st_size > 0
    df = pd.read_csv(out / "perf.csv")
    pl = df[df["section"] == "planners"].set_index("planner")
    assert set(pl.index) == {"mpnet_nr", "bit_star", "rrt_connect", "rrt_connect_compiled"}
    assert (pl["queries"] == pl["queries"].iloc[0]).all()  # the same queries for every planner
    nr = pl.loc["mpnet_nr"]
    assert nr["plan_median_s"] <= nr["time_median_s"]
    assert nr["cloud_s_share"] > 0 and nr["pnet_s_share"] > 0
    bit = pl.loc["bit_star"]
    assert bit["plan_median_s"] == bit["time_median_s"]
    assert (pl["rss_planning_mb"] > 50).all()
    ob = df[df["section"] == "obstacles"]
    assert sorted(set(ob["blocks"])) == [4, 14] and (ob["queries"] == 2).all()
    assert (out / "figures" / "perf_obstacles.png").stat().st_size > 0
    nets = df[df["section"] == "networks"]
    assert set(nets["what"]) == {
        "pnet_step",
        "pnet_step_compiled",
        "pnet_step_in_loop",
        "enet_encode",
        "enet_encode_compiled",
    }
    assert (nets["ratio_to_floor"] > 0).all()
    bt = df[df["section"] == "batched"].set_index("mode")
    assert set(bt.index) == {"one", "batched"} and (bt["queries"] == bt["queries"].iloc[0]).all()
    assert bt.loc["batched", "batch_mean"] > 1 and (bt["queries_per_s"] > 0).all()
    cx = df[df["section"] == "crossing"].set_index("check")
    assert set(cx.index) == {"state", "motion"} and (cx["env"] == "s2d").all()
    # through OMPL's callbacks a point robot's check costs many times the compiled one
    assert (cx["ompl_us"] > 3 * cx["compiled_us"]).all() and (cx["compiled_us"] > 0).all()
    assert "| Simple 2D | RRT-Connect |" in md.split("## The price of a check")[1]  # its crossings' share
    data = df[df["section"] == "data"]
    assert sorted(data["jobs"]) == [1, 2] and (data["paths"] > 0).all()


def test_random_blocks_are_seeded_and_inside_the_square():
    from mpnet.envs.scenes.generators import RandomBlocks

    a, b = RandomBlocks(28).make(3, "file", 0), RandomBlocks(28).make(3, "file", 0)
    assert len(a.centers) == 28 and (a.centers == b.centers).all()
    assert (a.lo >= -20).all() and (a.hi <= 20).all()
    assert not (RandomBlocks(28).make(4, "file", 0).centers == a.centers).all()
    with pytest.raises(ValueError):
        RandomBlocks(0)
