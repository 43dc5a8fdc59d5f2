"""End to end, in subprocesses: the documented experiments (Table I and its report, the findings,
the arm's pages, the learning curve) and the tools beside them (screenshot, bench_checkers)."""

import csv
import importlib.util
import shlex
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from tests.harness._cli import read_mcap, recheck

pytestmark = pytest.mark.slow  # every test here runs the CLI in a subprocess


def test_the_report_of_the_headline_sweep_prints_what_fills_table1(tmp_path, run_cli, sweeps_cache):
    """The README's headline sweep alone (two seeds, tiny): its report names Table I's missing
    planners and prints a command that, run as printed, fills Table I's row."""
    common = ["progress=false", "rerun=false", f"cache_dir={sweeps_cache}"]
    first, second = tmp_path / "hr", tmp_path / "rest"
    run_cli(
        "harness", "+env=rigid", "+planner=mpnet_hr", "scale=tiny", *common, f"hydra.sweep.dir={first}", "-m",
        "seed=0,1",
    )  # fmt: skip
    p = run_cli("harness.report", str(first), "--out", str(tmp_path / "r1"))
    (line,) = [x for x in p.stdout.splitlines() if x.startswith("rigid: no runs of Table I's")]
    assert "MPNet (NR), Informed-RRT*, BIT*" in line
    assert "What these runs lack" in (tmp_path / "r1" / "table1.md").read_text()
    args = shlex.split(line.split("to make them: ")[1])
    assert args[:3] == ["python", "-m", "harness"]
    run_cli(*args[2:], *common, f"hydra.sweep.dir={second}")  # as printed (plus where its logs go)
    p = run_cli("harness.report", str(first), str(second), "--out", str(tmp_path / "r2"))
    assert not [x for x in p.stdout.splitlines() if "Table I's" in x]
    table = (tmp_path / "r2" / "table1.csv").read_text()
    assert all(p in table for p in ("mpnet_nr", "mpnet_hr", "informed_rrt_star", "bit_star"))


def test_table1_experiment_and_report(tmp_path, run_cli, sweeps_cache):
    """The Table I sweep (narrowed to two planners and two seeds at tiny scale), then the
    report over its folder: every run is in results.csv and Table I, and its README gives the
    sweep's own command."""
    sweep = tmp_path / "sweep"
    run_cli(
        "harness",
        "-m",
        "+experiment=table1",
        "scale=tiny",
        "+env=s2d",
        "+planner=bit_star,mpnet_nr",
        "seed=0,1",
        "progress=false",
        "rerun=false",
        f"cache_dir={sweeps_cache}",
        f"hydra.sweep.dir={sweep}",
    )
    assert len(list(sweep.rglob("trials.mcap"))) == 4
    out = tmp_path / "report"
    run_cli("harness.report", str(sweep), "--out", str(out), "--paper")
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert sorted((r["planner"], r["split"], r["seeds"], r["queries"]) for r in rows) == [
        (p, s, "2", "8") for p in ("bit_star", "mpnet_nr") for s in ("seen", "unseen")
    ]
    table = (out / "table1.md").read_text()
    assert "MPNet (NR)" in table and "BIT*" in table and "paper" in table
    for fig in ("success", "success_vs_time", "time_boxplot", "example_s2d"):
        assert (out / "figures" / f"{fig}.png").stat().st_size > 0
    con = sqlite3.connect(out / "benchmark.db")
    assert con.execute("SELECT count(*) FROM runs").fetchone()[0] == 32
    con.close()
    readme = (out / "README.md").read_text()
    assert "Scale: tiny" in readme and "Compared with the paper" in readme
    logged = ["+experiment=table1", "scale=tiny", "progress=False", "rerun=False"]  # as Hydra logs them
    rest = shlex.join([*logged, f"cache_dir={sweeps_cache}"])
    assert f"\npython -m harness -m +env=s2d +planner=bit_star,mpnet_nr seed=0,1 {rest}\n" in readme


def test_the_findings_equal_quality_and_arm7_experiments_run(tmp_path, run_cli, sweeps_cache):
    """docs/mpnet.md's and README's experiments, each narrowed to one planner and seed at tiny
    scale (their sweeps' other planners run in test_every_env_and_planner_config_runs)."""
    common = ["scale=tiny", "seed=0", "splits=[unseen]", "rerun=false", "progress=false", f"cache_dir={sweeps_cache}"]
    for experiment, env, planner in (
        ("findings", "s2d", "mpnet_nr_random"),
        ("equal_quality", "s2d", "bit_star_to_nr_x1.1"),
        ("arm7", "arm7", "mpnet_hr_rrtc"),
    ):
        sweep = tmp_path / experiment
        run_cli(
            "harness", "-m", f"+experiment={experiment}", f"+env={env}", f"+planner={planner}", *common,
            f"hydra.sweep.dir={sweep}",
        )  # fmt: skip
        (f,) = sweep.rglob("trials.mcap")
        _, msgs = read_mcap(f)
        queries = [m for t, m in msgs if t == "/query"]
        assert len(queries) == 4 and recheck(msgs) == sum(q["success"] for q in queries)
        assert next(m for t, m in msgs if t == "/run")["planner"] == planner


def sweep_runs(sweep):
    """Each trials.mcap under a sweep folder, in path order: (its queries, its successes re-checked)."""
    out = []
    for f in sorted(sweep.rglob("trials.mcap")):
        _, msgs = read_mcap(f)
        out.append(([m for t, m in msgs if t == "/query"], recheck(msgs)))
    return out


def test_panda_mbm_variants_run_as_the_arm_page_shows(tmp_path, run_cli, sweeps_cache):
    """docs/arm.md's panda_mbm commands at tiny scale: the dense networks trained, then MPNet,
    its ablation and its named variants (a short budget: tiny networks rarely connect)."""
    common = ["scale=tiny", "progress=false", f"cache_dir={sweeps_cache}"]
    run_cli("harness.train", "+env=panda_mbm", "+planner=mpnet_nr_dense", *common, f"hydra.run.dir={tmp_path / 't'}")
    planners = "mpnet_nr,mpnet_nr_random,mpnet_hr_rrtc,mpnet_nr_clip,mpnet_nr_dense_clip,mpnet_hr_rrtc_clip"
    sweep = tmp_path / "sweep"
    run_cli(
        "harness", "-m", "+env=panda_mbm", f"+planner={planners}", *common, "splits=[unseen]", "budget_s=1",
        "rerun=false", f"hydra.sweep.dir={sweep}",
    )  # fmt: skip
    runs = sweep_runs(sweep)
    assert len(runs) == 6
    for queries, rechecked in runs:
        assert len(queries) == 4 and rechecked == sum(q["success"] for q in queries)


def test_the_mbm_experiment_runs_the_planners_it_names(tmp_path, run_cli, sweeps_cache, mbm_dir):
    """docs/arm.md's MotionBenchMaker experiment at tiny scale, one problem of each sample set:
    seven runs, the paper's recipe tagged as such in the report, every success re-checked."""
    sweep = tmp_path / "sweep"
    run_cli(
        "harness", "-m", "+experiment=panda_mbm_mbm", f"problems={mbm_dir}", "problems_per_set=1", "budget_s=1",
        "scale=tiny", "rerun=false", "progress=false", f"cache_dir={sweeps_cache}", f"hydra.sweep.dir={sweep}",
    )  # fmt: skip
    runs = sweep_runs(sweep)
    assert len(runs) == 7
    for queries, rechecked in runs:
        assert len(queries) == 3 and rechecked == sum(q["success"] for q in queries)
    run_cli("harness.report", str(sweep), "--out", str(tmp_path / "report"))
    ablations = (tmp_path / "report" / "ablations.csv").read_text()
    assert "paper_recipe" in ablations and "mpnet_nr_random" in ablations


def test_the_arm_in_two_minutes(tmp_path, run_cli, sweeps_cache, mbm_dir):
    """docs/arm.md's first commands at tiny scale: panda_mbm's MPNet-NR and -HR on the sample
    problems, one of each set (problems_per_set), every success re-checked."""
    sweep = tmp_path / "sweep"
    run_cli(
        "harness", "-m", "+env=panda_mbm", "+planner=mpnet_nr,mpnet_hr", f"problems={mbm_dir}", "problems_per_set=1",
        "budget_s=1", "scale=tiny", "rerun=false", "progress=false", f"cache_dir={sweeps_cache}",
        f"hydra.sweep.dir={sweep}",
    )  # fmt: skip
    files = sorted(sweep.rglob("trials.mcap"))
    assert len(files) == 2
    for f in files:
        _, msgs = read_mcap(f)
        queries = [m for t, m in msgs if t == "/query"]
        ids = ["bookshelf_small_panda/0001", "box_panda/0001", "table_pick_panda/0001"]
        assert sorted(q["query_id"] for q in queries) == ids
        assert recheck(msgs) == sum(q["success"] for q in queries)


def test_learning_curve_cli(tmp_path, run_cli, sweeps_cache):
    """The learning-curve experiment narrowed to two training-set sizes (tiny: 2 workspaces x 5
    and x 10 paths), then the learning
    curve from their logs: one row per size and split, the figure written."""
    run_cli(
        "harness",
        "-m",
        "+experiment=learning_curve",
        "+env=s2d",
        "+planner=mpnet_nr",
        "scale=tiny",
        "scale.train.paths=5,10",
        "rerun=false",
        "progress=false",
        f"hydra.sweep.dir={tmp_path / 'sweep'}",
        "hydra.sweep.subdir=p${scale.train.paths}",
        f"cache_dir={sweeps_cache}",  # tiny's own 10 paths: the networks other tests train
    )
    for paths in (5, 10):  # the bench logs the paths its networks were trained on (s2d's: all it asked)
        (f,) = (tmp_path / "sweep" / f"p{paths}").rglob("trials.mcap")
        run = next(m for t, m in read_mcap(f)[1] if t == "/run")
        assert run["facts"]["training_paths_built"] == 2 * paths
    p = run_cli("harness.report.learning_curve", str(tmp_path / "sweep"), "--out", str(tmp_path / "lc"))
    rows = list(csv.DictReader((tmp_path / "lc" / "learning_curve.csv").open()))
    assert sorted((r["split"], r["train_paths"]) for r in rows) == [
        ("seen", "10"),
        ("seen", "20"),
        ("unseen", "10"),
        ("unseen", "20"),
    ]
    assert all(r["queries"] == "4" for r in rows) and "wrote" in p.stdout
    assert (tmp_path / "lc" / "learning_curve.png").stat().st_size > 0


@pytest.mark.skipif(
    importlib.util.find_spec("playwright") is None or shutil.which("chromium") is None,
    reason="harness.screenshot's optional tools (playwright, chromium) are not installed",
)
def test_screenshot_of_a_recording(tmp_path, run_cli, mbm_dir):
    run_cli(
        "harness", "+env=arm7", "+planner=rrt_connect", f"problems={mbm_dir / 'box_panda'}", f"hydra.run.dir={tmp_path}"
    )
    run_cli("harness.screenshot", str(tmp_path / "trials.rrd"), str(tmp_path / "shot.png"), "--wait", "40")
    from PIL import Image

    img = np.asarray(Image.open(tmp_path / "shot.png").convert("RGB"), float)
    assert img.shape[:2] == (1000, 1600) and img.std() > 20  # the viewer drew something, not a blank page
    rrd = str(tmp_path / "trials.rrd").encode()
    left = []  # the viewer is stopped with its wrapper (it once outlived it, spinning a core)
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if rrd in cmdline.read_bytes():
                left.append(cmdline.parent.name)
        except OSError:
            pass
    assert not left, f"viewer processes left running: {left}"


def test_screenshot_needs_a_recording(tmp_path, run_cli):
    p = run_cli("harness.screenshot", str(tmp_path / "none.rrd"), str(tmp_path / "x.png"), check=False)
    assert p.returncode == 1 and "no recording at" in p.stderr


def test_bench_checkers(run_cli, tmp_path):
    args = ("arm7", "rigid", "--workspaces", "1", "--repeats", "1")
    p = run_cli("harness.bench_checkers", *args, "--out", str(tmp_path / "checkers"))
    lines = p.stdout.splitlines()
    end = next(i for i, line in enumerate(lines) if line.startswith("p90:"))
    rows = {tuple(line.split()[:2]) for line in lines[1:end]}
    assert rows == {
        ("arm7", "spheres"),
        ("arm7", "spheres_swept"),
        ("arm7", "pybullet"),
        ("rigid", "native"),
        ("rigid", "fcl"),
    }
    assert lines[end + 1].startswith("arm7 spheres / pybullet (median rates, the same states): states ")
    report = (tmp_path / "checkers" / "README.md").read_text()  # what FINDINGS quotes: with its provenance
    assert "Generated by `python -m harness.bench_checkers arm7 rigid --workspaces 1 --repeats 1` at git " in report
    assert "on each of the generated workspaces, 1 repeats" in report
    assert "arm7 spheres / pybullet (median rates" in report
    bad = run_cli("harness.bench_checkers", "arm8", check=False)
    assert bad.returncode == 2 and "unknown env 'arm8'" in bad.stderr
    bad = run_cli("harness.bench_checkers", "rigid", "--repeats", "0", check=False)
    assert bad.returncode == 2 and "--repeats must be at least 1" in bad.stderr
