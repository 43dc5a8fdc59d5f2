"""No tracebacks from user input: a bad config value, planner setting, output or cache
folder, or problem file is one line on stderr naming the key, file or folder, and a
non-zero exit (2 for a mistake in the command, docs/reliability.md "Exit status"); checked
before any expensive set-up, and a refused run leaves no run folder behind."""

from __future__ import annotations

import json
import os

import pytest
from omegaconf import OmegaConf

from harness.core.cli import UsageError, check_files, check_groups, check_keys, check_output_dirs, check_plus
from harness.core.cli_help import ENTRIES
from harness.core.settings import settings_of


@pytest.mark.parametrize(
    "override,key",
    [
        ("jobs=-3", "jobs"),
        ("jobs=0", "jobs"),
        ("jobs=1.5", "jobs"),
        ("env.data_seed=-1", "env.data_seed"),
        ("env.points_per_block=0", "env.points_per_block"),
        ("scale.test.seen.queries=-2", "scale.test.seen.queries"),
        ("scale.train.paths=0", "scale.train.paths"),
        ("scale.fit.batch_size=0", "scale.fit.batch_size"),
        ("train.lr=-1", "train.lr"),
        ("train.lam=-0.1", "train.lam"),
        ("train.val_fraction=1.5", "train.val_fraction"),
        ("train.patience=0", "train.patience"),
        ("planner.stop=bogus", "planner.stop"),
        ("planner.cost_factor=abc", "planner"),  # float("abc") in the constructor: a ValueError without a key
        ("planner.cost_factor=null", "planner"),  # and a TypeError
    ],
)
@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_nonsense_config_value_is_refused_naming_the_key(override, key, compose_config):
    cfg = compose_config(["+env=s2d", "+planner=bit_star", "scale=tiny", override])
    with pytest.raises(UsageError, match=f"config key {key}"):
        settings_of(cfg)


@pytest.mark.parametrize(
    "planner,override", [("mpnet_nr", "planner.max_steps=abc"), ("mpnet_hr", "planner.fallback=x")]
)
def test_bad_mpnet_setting_is_refused_without_models(planner, override, compose_config, tmp_path):
    """settings_of runs the planner's constructor with a models folder that stops it:
    the settings are refused, and nothing is trained or built."""
    cfg = compose_config(["+env=s2d", f"+planner={planner}", "scale=tiny", override, f"cache_dir={tmp_path}"])
    with pytest.raises(UsageError, match="config key planner"):
        settings_of(cfg)
    assert list(tmp_path.iterdir()) == []


def test_good_config_passes_without_building(compose_config, tmp_path):
    cfg = compose_config(["+env=s2d", "+planner=bit_star_to_nr", "scale=tiny", f"cache_dir={tmp_path}"])
    settings_of(cfg)
    assert list(tmp_path.iterdir()) == []


def test_output_dir_that_cannot_be_made_is_one_line(tmp_path):
    (tmp_path / "afile").write_text("x")
    for arg in (f"hydra.run.dir={tmp_path / 'afile' / 'run'}", "hydra.sweep.dir=/proc/mpnet-bench/${now:%H}"):
        with pytest.raises(UsageError, match=r"config key hydra\.(run|sweep)\.dir: cannot create") as info:
            check_output_dirs([arg])
        assert "\n" not in str(info.value)


def test_output_dir_check_leaves_nothing_behind(tmp_path):
    check_output_dirs([f"hydra.run.dir={tmp_path / 'a' / 'b'}", f"hydra.sweep.dir={tmp_path}/c/${{now:%H}}", "seed=1"])
    assert list(tmp_path.iterdir()) == []


def test_output_dir_check_survives_jobs_checking_the_same_folder(tmp_path):
    """Two jobs of a sweep (or two `harness.data` runs) check one run dir at once: a folder
    removed by the other job between our mkdir and our write is not an error (CI failed so)."""
    from concurrent.futures import ThreadPoolExecutor

    run = tmp_path / "run" / "dir"

    def hammer(_):
        for _ in range(300):
            check_output_dirs([f"hydra.run.dir={run}"])

    with ThreadPoolExecutor(4) as pool:
        list(pool.map(hammer, range(4)))
    assert not [f for f in tmp_path.rglob("*") if not f.is_dir()]  # at most an empty folder, which Hydra makes anyway


BENCH = ["+env=s2d", "+planner=bit_star"]


@pytest.mark.parametrize(
    "argv,message",
    [
        (["env=s2d", "+planner=bit_star"], "write +env=s2d (env is a choice added with +)"),
        (["+env=s2d", "planner=bit_star"], "write +planner=bit_star (planner is a choice added with +)"),
        (["-m", "env=s2d,c2d"], "write +env=s2d,c2d (env is a choice added with +)"),
        ([*BENCH, "+scale=tiny"], "write scale=tiny (scale has a default choice"),
    ],
)
def test_group_with_or_without_plus_names_the_fix(argv, message):
    with pytest.raises(UsageError) as info:
        check_plus(argv)
    assert str(info.value).startswith(message)


@pytest.mark.parametrize(
    "argv,message",
    [
        ([*BENCH, "budget=5"], "unknown config key budget (did you mean budget_s?)"),
        ([*BENCH, "+budget=5"], "unknown config key budget (did you mean budget_s?)"),
        ([*BENCH, "planner.stopp=x"], "unknown config key planner.stopp (did you mean planner.stop?)"),
        ([*BENCH, "hydra.run.dirr=x"], "unknown config key hydra.run.dirr (did you mean hydra.run.dir?)"),
        ([*BENCH, "+budget_s=3"], "write budget_s=3 (budget_s is already in the config"),
        ([*BENCH, "planner.params.rewire_factor=1.1"], "write +planner.params.rewire_factor=1.1"),
        (["+experiment=table1", "-m", "+planner.stopp=1"], "unknown config key planner.stopp"),
        (
            ["+env=s2d", "hydra/launcher=slurm", "hydra.launcher.partitio=cpu"],
            "unknown config key hydra.launcher.partitio (did you mean hydra.launcher.partition?)",
        ),
    ],
)
def test_unknown_key_names_the_closest_real_one(argv, message):
    with pytest.raises(UsageError) as info:
        check_keys(argv, "config")
    assert str(info.value).startswith(message) and "\n" not in str(info.value)


@pytest.mark.parametrize(
    "argv,config",
    [
        (
            [*BENCH, "budget_s=5", "seed=1", "planner.stop=cost", "hydra.run.dir=x", "scale=tiny", "env.collision=fcl"],
            "config",
        ),
        ([*BENCH, "+planner.params.rewire_factor=1.1", "planner.params={range: 2}"], "config"),
        (["+env=s2d", "+planner=rrt_star", "+env.planner_range=0.5", "~problems"], "config"),
        (["+env=s2d", "+planner=mpnet_nr,bit_star", "-m", "seed=0,1", "planner.max_steps=10"], "config"),
        (["+experiment=table1", "-m", "planner.name=x", "env.collision=fcl"], "config"),
        (["+env=s2d", "scale=tiny", "train.lr=0.1", "train.devices=2", "-m", "hydra/launcher=local"], "config"),
        (
            ["+env=s2d", "shards=3", "hydra/launcher=slurm", "hydra.launcher.partition=cpu", "-m", "shard=range(0,3)"],
            "data",
        ),
        (["perf=tiny", "perf.envs=[s2d]", "out=/tmp/x"], "perf_main"),
    ],
)
def test_real_keys_pass_the_key_check(argv, config):
    check_keys(argv, config)


@pytest.mark.parametrize("config", sorted({e.config for e in ENTRIES.values()}))
def test_keys_passed_without_composing_are_in_every_composition(config):
    """check_keys leaves the keys of a command's own config file (and Hydra's output folders)
    unchecked by composition: each is in the composed config, whatever the env, planner,
    scale or experiment, and holds a value (`budget_s=1` replaces it; no + is needed)."""
    from hydra import compose, initialize_config_dir

    from harness.core.cli import CONF_DIR, _lookup, _plain_keys

    choices = [[], ["+env=arm7", "+planner=mpnet_hr", "scale=paper"], ["+experiment=findings"], ["+env=c3d"]]
    for overrides in choices if config != "perf_main" else [[]]:
        with initialize_config_dir(str(CONF_DIR), version_base="1.3"):
            cfg = compose(config, overrides, return_hydra_config=True)
        assert {key: _lookup(cfg, key) for key in _plain_keys(config)} == dict.fromkeys(_plain_keys(config), "known")


@pytest.mark.slow  # the CLI in subprocesses
@pytest.mark.parametrize("prog", ["harness", "harness.data", "harness.train", "harness.perf", "harness.overhead"])
def test_help_has_usage_choices_keys_and_examples(prog, run_cli):
    out = run_cli(prog, "--help").stdout
    assert out.startswith(f"usage: python -m {prog} ") and "Compose your configuration" not in out
    assert "examples:" in out and out.count(f"  python -m {prog} ") >= 3 and "--hydra-help" in out
    assert ("+env=" in out and "s2d" in out and "scale=" in out) or "perf=" in out
    assert "Compose your configuration" in run_cli(prog, "--hydra-help").stdout
    if prog == "harness":  # the files a run writes, by the names the log gives them (it said trials.csv)
        from harness.log.csv import CSV_NAME

        assert all(f"{name}" in out.split("\n\n")[1] for name in ("trials.mcap", CSV_NAME, "trials.rrd"))


@pytest.mark.slow  # the CLI in subprocesses
@pytest.mark.parametrize(
    "args,line",
    [
        (["env=s2d", "+planner=bit_star"], "error: write +env=s2d (env is a choice added with +)"),
        ([*BENCH, "budget=5"], "error: unknown config key budget (did you mean budget_s?)"),
        ([*BENCH, "+budget=5"], "error: unknown config key budget (did you mean budget_s?)"),
    ],
)
def test_override_mistakes_are_one_line_with_the_fix(args, line, run_cli, tmp_path):
    p = run_cli("harness", *args, "scale=tiny", f"hydra.run.dir={tmp_path / 'run'}", check=False)
    assert p.returncode == 2 and p.stderr.strip() == line and not (tmp_path / "run").exists()


@pytest.mark.slow  # the CLI in subprocesses
def test_more_workspaces_than_the_env_makes_is_one_line_naming_the_key(tmp_path, run_cli):
    """s2d's layouts are the original's 100 + 10: asking for more was a traceback from deep in
    the build."""
    base = ("+env=s2d", "scale=tiny", "progress=false", f"cache_dir={tmp_path / 'c'}")
    for prog, key, more in (
        ("harness.data", "scale.train.workspaces", "scale.train.workspaces=101"),
        ("harness.data", "scale.test.unseen.workspaces", "scale.test.unseen.workspaces=11"),
    ):
        p = run_cli(prog, *base, more, f"hydra.run.dir={tmp_path / 'r'}", check=False)
        assert p.returncode != 0 and "Traceback" not in p.stderr, p.stderr
        lines = p.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"error: config key {key}: env s2d: the "), p.stderr
        assert lines[0].endswith(" asked") and not (tmp_path / "c").exists()


@pytest.mark.slow  # the CLI in subprocesses
def test_cli_user_errors_are_one_line(tmp_path, run_cli):
    """The filesystem and file cases through the CLI: an output dir under a regular file
    (Hydra's traceback before), a cache under one, a problem file with a NaN nested in a
    list, and a bad planner setting, which is refused before the cache is touched."""
    (tmp_path / "afile").write_text("x")
    bad = {"format": "mpnet-bench/problems@1", "env": "s2d", "workspaces": [{"id": [[float("nan")]]}]}
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    base = ("harness", "+env=s2d", "+planner=bit_star", "scale=tiny", "progress=false")
    cases = [
        ((f"hydra.run.dir={tmp_path / 'afile' / 'run'}",), "config key hydra.run.dir"),
        ((f"cache_dir={tmp_path / 'afile' / 'cache'}", f"hydra.run.dir={tmp_path / 'r1'}"), "afile/cache"),
        ((f"problems={tmp_path / 'bad.json'}", f"hydra.run.dir={tmp_path / 'r2'}"), "bad.json: workspace #0"),
        (("planner.stop=bogus", f"cache_dir={tmp_path / 'c'}", f"hydra.run.dir={tmp_path / 'r3'}"), "planner.stop"),
    ]
    for args, needle in cases:
        p = run_cli(*base, *args, check=False)
        assert p.returncode != 0 and "Traceback" not in p.stderr, p.stderr
        assert len(p.stderr.strip().splitlines()) == 1 and needle in p.stderr, p.stderr
    assert not (tmp_path / "c").exists()
    p = run_cli("harness.train", "+env=s2d", "scale=tiny", f"cache_dir={tmp_path / 'afile'}", "jobs=-3", check=False)
    assert p.returncode == 2 and p.stderr.strip() == "error: config key jobs: expected an integer >= 1, got -3"


@pytest.mark.parametrize(
    "argv,close",
    [
        (["+env=s2dd", "+planner=bit_star"], "unknown env 's2dd' (did you mean s2d? choices: arm7, c2d"),
        (["+env=s2d", "+planner=bitstar"], "unknown planner 'bitstar' (did you mean bit_star? choices: bit_star,"),
        (["-m", "+env=s2d,rigd", "+planner=bit_star"], "unknown env 'rigd' (did you mean rigid? choices:"),
    ],
)
def test_unknown_choice_names_the_closest_one(argv, close):
    with pytest.raises(UsageError) as info:
        check_groups(argv, ("env", "planner"))
    assert str(info.value).startswith(close) and "hydra.searchpath" in str(info.value)


def test_missing_problem_file_is_named_before_any_work(compose_config, tmp_path):
    """On the command line (before Hydra makes a run folder), and in the composed config (a
    path given some other way, as `python -m harness` makes it absolute)."""
    with pytest.raises(UsageError, match=r"^problems=no/such/file\.json: no such file or folder$"):
        check_files([*BENCH, "problems=no/such/file.json"])
    with pytest.raises(UsageError, match=r"^problems=b\.json: no such file"):
        check_files(["-m", *BENCH, f"problems={tmp_path},b.json"])
    check_files([*BENCH, f"problems={tmp_path}", "problems=null", "~problems"])  # a folder (MotionBenchMaker's)
    cfg = compose_config([*BENCH, "scale=tiny", f"problems={tmp_path / 'none.json'}"])
    with pytest.raises(UsageError, match=f"^problems={tmp_path / 'none.json'}: no such file or folder$"):
        settings_of(cfg)


def test_missing_problem_file_is_one_line_exit_2_and_no_run_folder(run_cli, tmp_path):
    p = run_cli("harness", *BENCH, "problems=no/such/file.json", cwd=tmp_path, check=False)
    assert (p.returncode, p.stderr) == (2, "error: problems=no/such/file.json: no such file or folder\n")
    assert list(tmp_path.iterdir()) == []  # no outputs/<date>/<time>/


@pytest.mark.slow  # the CLI in subprocesses
def test_a_refused_run_leaves_no_run_folder(run_cli, tmp_path):
    """Mistakes found in the job, after Hydra made its folder: exit 2, and the folder is removed
    with those made for it; one that was there before is kept (emptied of Hydra's files if it
    was empty), and a sweep's job folder goes too."""
    for mistake in ("budget_s=abc", "seed=-1", "splits=[bogus]"):
        p = run_cli("harness", *BENCH, "scale=tiny", mistake, cwd=tmp_path, check=False)
        assert p.returncode == 2 and len(p.stderr.splitlines()) == 1 and "config key" in p.stderr, p.stderr
        assert list(tmp_path.iterdir()) == [], mistake
    (tmp_path / "empty").mkdir()
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "notes.txt").write_text("mine")
    refused = ("harness", *BENCH, "scale=tiny", "seed=-1")
    for folder in ("new/nested", "empty", "full"):
        assert run_cli(*refused, f"hydra.run.dir={tmp_path / folder}", cwd=tmp_path, check=False).returncode == 2
    assert not (tmp_path / "new").exists() and list((tmp_path / "empty").iterdir()) == []
    assert (tmp_path / "full" / "notes.txt").read_text() == "mine"
    p = run_cli(*refused, f"hydra.sweep.dir={tmp_path / 'sweep'}", "-m", cwd=tmp_path, check=False)
    assert p.returncode == 2 and not (tmp_path / "sweep" / "s2d" / "bit_star" / "seed-1").exists()


class NoNameArgument:
    """A planner of one's own whose constructor takes no `name`, and whose object has one."""

    name = "its_own_name"

    def __init__(self, tries: int = 1):
        self.tries = int(tries)

    def solve(self, problem, budget_s):
        from mpnet.planners.base import EXACT, NO_SOLUTION, Result, check_endpoints

        if (invalid := check_endpoints(problem)) is not None:
            return invalid
        if problem.checker.motion_valid(problem.start, problem.goal):
            return Result([problem.start.tolist(), problem.goal.tolist()], EXACT)
        return Result(None, NO_SOLUTION)


@pytest.mark.parametrize(
    "section,label",
    [
        ({"name": "mine", "tries": 2}, "mine"),  # the config's name, though the constructor takes none
        ({"tries": 2}, "its_own_name"),  # no name in the config: the object's
    ],
)
def test_an_own_planner_is_labelled_by_its_config_or_its_own_name(section, label, compose_config):
    cfg = compose_config([*BENCH, "scale=tiny"])
    cfg.planner = OmegaConf.create({"_target_": f"{__name__}.NoNameArgument", **section})
    run = settings_of(cfg)
    planner = run.planner.make({"env": run.env.spec, "seed": run.seed})
    assert planner.tries == 2 and run.planner.label(planner) == label


@pytest.mark.slow  # the CLI in subprocesses
def test_an_own_planner_is_logged_under_its_label(run_cli, tmp_path, problems_dir):
    """README "Benchmark your own planner" with a constructor that takes no `name`: the run's
    /run message and summary name it by its config's `name`, else by its object's."""
    import inspect

    from harness.log import MCAP_NAME, read_log

    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "own_planner.py").write_text(inspect.getsource(NoNameArgument))
    planners = tmp_path / "conf" / "planner"
    planners.mkdir(parents=True)
    (planners / "own_named.yaml").write_text("_target_: own_planner.NoNameArgument\nname: own_named\ntries: 2\n")
    (planners / "own_nameless.yaml").write_text("_target_: own_planner.NoNameArgument\ntries: 2\n")
    env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(tmp_path / "pkg"), os.environ.get("PYTHONPATH")]))}
    for planner, label in (("own_named", "own_named"), ("own_nameless", "its_own_name")):
        run = tmp_path / planner
        p = run_cli(
            "harness", "+env=s2d", f"+planner={planner}", f"hydra.searchpath=[file://{tmp_path / 'conf'}]",
            f"problems={problems_dir / 's2d.json'}", "rerun=false", "progress=false", f"hydra.run.dir={run}", env=env,
        )  # fmt: skip
        assert f"s2d / {label} / seed 0: {run}" in p.stdout
        msgs, _ = read_log(run / MCAP_NAME, ("/run",))
        assert msgs[0].data["planner"] == label
