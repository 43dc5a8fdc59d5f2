"""Every command in README.md and docs/*.md is run by a test, checked from the text alone.

A command is a line of a fenced code block (```bash or a bare ```) that runs `python -m ...`,
`pip install ...` or `jupyter ...` (after environment assignments such as `PYTHONPATH=$E ` or
a launcher prefix such as `srun -p cpu -c 32 `); comments are stripped, backslash-continued
lines joined, and `a && b` is two commands. docs/research/ is not read. (The reading is
tests/doc_commands.py's.)

Each command is in TESTED, naming the test that runs it (at tiny scale, with a test's paths
for the page's placeholders), or in UNTESTED, saying why no test can run it and what is run in
its stead. A new command fails here until it is given a test or dropped; a test renamed, or one
that no longer names the command's module and overrides, fails here too. The folders the
commands write are ignored by git, and no page or comment cites a file a clone lacks
(tests/test_docs_files.py).
"""

from __future__ import annotations

import re
import tomllib

from tests.doc_commands import REPO, commands_in, documented_commands, required_mentions, source_of_test

CLI = "tests/harness/test_cli.py::"
CLI_CONFIGS = "tests/harness/test_cli_configs.py::"
CLI_EXPERIMENTS = "tests/harness/test_cli_experiments.py::"
TABLE1 = CLI_EXPERIMENTS + "test_table1_experiment_and_report"
OWN_PLANNER = CLI + "test_a_planner_of_ones_own_runs_beside_bit_star_and_in_the_report"
MBM_RUN = CLI + "test_mbm_problems_run_named_by_scene"
NOTEBOOK = "tests/harness/report/test_notebook.py::test_notebook_runs_on_a_tiny_run"
PERF = "tests/harness/test_perf.py::test_perf_writes_every_section"
SHARDS = "tests/harness/test_cluster.py::test_sharded_data_build_merges_into_the_unsharded_dataset"
EXPERIMENTS = CLI_EXPERIMENTS + "test_the_findings_equal_quality_and_arm7_experiments_run"
PANDA_MBM = CLI_EXPERIMENTS + "test_panda_mbm_variants_run_as_the_arm_page_shows"
ARM_FIRST = CLI_EXPERIMENTS + "test_the_arm_in_two_minutes"
SUMMARY = "tests/harness/report/test_summary.py::test_command_writes_both_files_and_refuses_a_readme_without_markers"

# documented command (as documented_commands() normalises it) -> the test that runs it
FILES_ONLY = "tests/harness/core/test_configs.py::test_envs_of_problem_files_only_say_what_they_lack"
TESTED = {
    # README.md
    "python -m harness +env=s2d +planner=bit_star": CLI + "test_bench_tiny_s2d",
    "python -m harness +env=rigid +planner=rrt_connect -m seed=0,1,2,3,4": CLI + "test_used_by_form_multirun",
    "python -m harness +env=ENV +planner=PLANNER [seed=N] [scale=S] [problems=FILE] [budget_s=T]": (
        CLI_CONFIGS + "test_every_env_and_planner_config_runs"
    ),
    "python -m harness -m +env=s2d,c2d,c3d,rigid +planner=bit_star,informed_rrt_star": TABLE1,
    "python -m harness.screenshot outputs/<date>/<time>/trials.rrd shot.png": CLI_EXPERIMENTS
    + "test_screenshot_of_a_recording",
    "python -m harness.report multirun/<date>/<time> [more dirs...] [--paper]": TABLE1,
    "python -m harness.report --label old=runs/a --label new=runs/b": (
        "tests/harness/report/test_report_labels.py::test_labelled_report_from_tiny_runs"
    ),
    "python -m harness -m +experiment=table1": TABLE1,
    "python -m harness.report <the sweeps of reports/table1/> --paper --out reports/table1": TABLE1,
    "python -m harness.report.summary": SUMMARY,
    (
        "PYTHONPATH=$E python -m harness +env=s2d +planner=batch_prm scale=tiny "
        '"hydra.searchpath=[file://$PWD/$E/conf]" hydra.run.dir=runs/prm'
    ): OWN_PLANNER,
    "python -m harness +env=s2d +planner=bit_star scale=tiny hydra.run.dir=runs/bit": OWN_PLANNER,
    "python -m harness.report runs/prm runs/bit --out runs/report": OWN_PLANNER,
    # docs/arm.md
    "python -m harness +env=arm7 +planner=rrt_connect problems=tests/data/mbm": MBM_RUN,
    "python -m harness +env=arm7 +planner=mpnet_hr problems=path/to/problems/box_panda": (
        CLI_CONFIGS + "test_paper_scale_dry_run"
    ),
    "python -m harness.fetch_mbm data/mbm": (
        "tests/mpnet/envs/arm/test_arm.py::test_fetch_mbm_unpacks_the_panda_problems_of_an_sdist"
    ),
    # a robot installed from an sdist (a toy robot: the suite cannot download the UR5's files)
    "python -m harness.fetch_mbm data/mbm --robot ur5 --robot fetch": (
        "tests/mpnet/envs/arm/test_robot_files.py::test_fetch_mbm_installs_a_robot_without_visuals_and_spherizes_it"
    ),
    # composed and refused without the robot's files, naming the command that installs them
    "python -m harness +env=mbm_ur5 +planner=rrt_connect problems=data/mbm/problems": FILES_ONLY,
    "python -m harness +env=mbm_fetch +planner=rrt_connect_compiled problems=data/mbm/problems": FILES_ONLY,
    "python -m harness +env=arm7 +planner=rrt_connect problems=data/mbm/problems": MBM_RUN,
    "python -m harness.perf.crossing --out reports/rrt_connect_compiled/crossing": (
        "tests/harness/test_perf.py::test_crossing_command_writes_its_table"
    ),
    "python -m harness +env=panda_mbm +planner=rrt_connect_compiled problems=data/mbm/problems": (
        "tests/mpnet/planners/compiled/test_rrt_connect_compiled.py::test_rrt_connect_compiled_runs_mbm_problems_from_the_command_line"
    ),
    (
        "python -m harness.sphere_audit --problems data/mbm/problems --configurations 1000000 --motions 100000 "
        "--out reports/sphere_audit"
    ): ("tests/mpnet/envs/checkers/test_spheres.py::test_sphere_audit_cli"),
    "python -m harness.bench_checkers arm7": CLI_EXPERIMENTS + "test_bench_checkers",
    "python -m harness +experiment=arm7": EXPERIMENTS,
    "python -m harness +env=panda_mbm +planner=mpnet_nr problems=tests/data/mbm": ARM_FIRST,
    "python -m harness +env=panda_mbm +planner=mpnet_hr problems=tests/data/mbm budget_s=2": ARM_FIRST,
    "python -m harness +env=panda_mbm +planner=mpnet_nr problems=data/mbm/problems problems_per_set=5": ARM_FIRST,
    "python -m harness +env=panda_mbm +planner=mpnet_hr problems=data/mbm/problems problems_per_set=5": ARM_FIRST,
    "python -m harness +env=panda_mbm +planner=mpnet_nr problems=data/mbm/problems": PANDA_MBM,
    "python -m harness +env=panda_mbm +planner=mpnet_nr_random problems=data/mbm/problems": PANDA_MBM,
    "python -m harness +env=panda_mbm +planner=mpnet_hr_rrtc": PANDA_MBM,
    "python -m harness +env=panda_mbm +planner=mpnet_nr_clip problems=data/mbm/problems": PANDA_MBM,
    "python -m harness.train +env=panda_mbm +planner=mpnet_nr_dense": PANDA_MBM,
    "python -m harness +env=panda_mbm +planner=mpnet_nr_dense_clip problems=data/mbm/problems": PANDA_MBM,
    "python -m harness +env=panda_mbm +planner=mpnet_hr_rrtc_clip problems=data/mbm/problems": PANDA_MBM,
    "python -m harness -m +experiment=panda_mbm_mbm problems=data/mbm/problems": (
        CLI_EXPERIMENTS + "test_the_mbm_experiment_runs_the_planners_it_names"
    ),
    (
        "python -m harness +env=panda_mbm +planner=mpnet_nr +planner.networks.bounded=true "
        "+planner.networks.dagger_rounds=1"
    ): "tests/mpnet/planners/test_dagger.py::test_a_dagger_round_trains_on_the_expert_paths_and_the_labelled_rollouts",
    # docs/cluster.md
    "python -m harness.train scale=tiny hydra/launcher=local -m +env=s2d,c2d": (
        "tests/harness/test_cluster.py::test_a_training_sweep_on_the_local_launcher"
    ),
    "python -m harness.report multirun/<date>/<time>": TABLE1,
    "python -m harness.data +env=s2d scale=tiny shards=3 hydra/launcher=local -m 'shard=range(0,3)'": SHARDS,
    "python -m harness.data +env=s2d scale=tiny shards=3 merge=true": SHARDS,
    "python -m harness +env=s2d +planner=rrt_connect,mpnet_nr scale=tiny hydra/launcher=local -m seed=0,1": (
        "tests/harness/test_cluster.py::test_sweep_of_two_seeds_on_a_launcher"
    ),
    # docs/mpnet.md
    "python -m harness +env=s2d +planner=mpnet_nr": TABLE1,
    "python -m harness.compile_kernels": "tests/harness/test_compile_kernels.py::test_compile_kernels_cli",
    "python -m harness.data +env=s2d [scale=S]": (
        "tests/mpnet/data/test_data.py::test_data_cli_builds_once_under_concurrency"
    ),
    "python -m harness.train +env=s2d [scale=S]": (
        "tests/harness/artifacts/test_artifact_integrity.py::test_damaged_checkpoint_and_dataset_are_rebuilt_end_to_end"
    ),
    "python -m harness.report multirun/<date>/<time-1> multirun/<date>/<time-2> --paper --out reports/table1": TABLE1,
    "python -m harness.report.learning_curve multirun/<date>/<time> --out reports/learning_curve": (
        CLI_EXPERIMENTS + "test_learning_curve_cli"
    ),
    "python -m harness +env=rigid +planner=mpnet_hr -m seed=0,1,2,3,4": CLI_CONFIGS
    + "test_mpnet_sweep_builds_artifacts_once",
    "python -m harness -m +experiment=findings": EXPERIMENTS,
    "python -m harness -m +experiment=equal_quality": EXPERIMENTS,
    "python -m harness.export_weights -m +env=s2d,c2d,c3d,rigid,arm7,panda_mbm scale=quick": (
        "tests/mpnet/models/test_pretrained.py::test_exported_set_plans_as_its_checkpoint"
    ),
    "python -m harness.export_weights +env=panda_mbm +planner=mpnet_nr_paper scale=quick": (
        "tests/mpnet/models/test_pretrained.py::test_exported_set_plans_as_its_checkpoint"
    ),
    "python -m harness -m +experiment=learning_curve": CLI_EXPERIMENTS + "test_learning_curve_cli",
    # docs/performance.md
    "python -m harness.perf": PERF,
    "python -m harness.perf perf=tiny out=/tmp/p": PERF,
    "python -m harness.overhead +env=s2d +planner=bit_star": CLI + "test_overhead_benchmark",
    "python -m harness.bench_checkers arm7 rigid": CLI_EXPERIMENTS + "test_bench_checkers",
    "python -m harness.bench_checkers --out reports/perf/checkers": CLI_EXPERIMENTS + "test_bench_checkers",
    # docs/reports.md
    "python -m harness +env=s2d +planner=bit_star scale=tiny hydra.run.dir=outputs/tiny": NOTEBOOK,
    "MPNET_FIGURE=outputs/tiny/query.png jupyter execute examples/explore_a_run.ipynb": NOTEBOOK,
    "python -m harness.recheck outputs/<date>/<time> [more paths...] [--step 0.001] [--out DIR] [--jobs 2]": (
        "tests/harness/test_recheck.py::test_files_rechecked_in_parallel_report_as_one_by_one"
    ),
}

# Commands no test can run by their nature -> (why, what is run in their stead): a command of
# the same page that is in TESTED (or itself stood in for by a file), or a repository file
# that runs the command verbatim (CI's script).
LOCAL_SHARDS = "python -m harness.data +env=s2d scale=tiny shards=3 hydra/launcher=local -m 'shard=range(0,3)'"
LOCAL_TRAIN = "python -m harness.train scale=tiny hydra/launcher=local -m +env=s2d,c2d"
LOCAL_SWEEP = "python -m harness +env=s2d +planner=rrt_connect,mpnet_nr scale=tiny hydra/launcher=local -m seed=0,1"
HEADLESS_NOTEBOOK = "MPNET_FIGURE=outputs/tiny/query.png jupyter execute examples/explore_a_run.ipynb"
UNTESTED = {
    # README.md
    'pip install -e ".[dev]"': ("installs into the environment the suite runs in", ".ci/run"),
    "python -m pytest -q -n auto": ("the test suite itself: run from a test it would recurse", ".ci/run"),
    'python -m pytest -m "not slow" -q -n auto': (
        "the test suite's fast half: run from a test it would recurse",
        "python -m pytest -q -n auto",
    ),
    # docs/cluster.md
    'pip install -e ".[cluster]"': (
        "installs into the environment; its pins are in the dev extra (test_the_cluster_extra_is_in_the_dev_extra)",
        LOCAL_SWEEP,
    ),
    (
        "python -m harness.data +env=s2d scale=paper cache_dir=$CACHE shards=100 jobs=1 progress=false "
        "hydra/launcher=slurm hydra.launcher.partition=cpu -m 'shard=range(0,100)'"
    ): ("a SLURM array job (hydra/launcher=slurm)", LOCAL_SHARDS),
    "srun -p cpu -c 32 python -m harness.data +env=s2d scale=paper cache_dir=$CACHE shards=100 merge=true jobs=32": (
        "a SLURM job (srun)",
        "python -m harness.data +env=s2d scale=tiny shards=3 merge=true",
    ),
    (
        "python -m harness.train scale=paper cache_dir=$CACHE train.accelerator=gpu train.devices=1 "
        "hydra/launcher=slurm_gpu hydra.launcher.partition=gpu -m +env=s2d,c2d,c3d,rigid"
    ): ("SLURM GPU jobs (hydra/launcher=slurm_gpu, train.accelerator=gpu)", LOCAL_TRAIN),
    (
        "python -m harness.train +env=s2d scale=paper cache_dir=$CACHE train.accelerator=gpu train.devices=4 "
        "train.strategy=ddp_spawn hydra/launcher=slurm_gpu hydra.launcher.partition=gpu -m seed=0"
    ): ("a SLURM job on 4 GPUs (hydra/launcher=slurm_gpu, train.devices=4)", LOCAL_TRAIN),
    (
        "python -m harness +env=s2d,c2d,c3d,rigid +planner=bit_star,rrt_star,mpnet_nr,mpnet_hr scale=stats "
        "cache_dir=$CACHE hydra/launcher=slurm hydra.launcher.partition=cpu -m seed=0,1,2"
    ): ("SLURM jobs (hydra/launcher=slurm)", LOCAL_SWEEP),
    # docs/reports.md
    "pip install notebook": ("installs from the network, for the interactive notebook only", HEADLESS_NOTEBOOK),
    "jupyter notebook examples/explore_a_run.ipynb": ("interactive: a browser session", HEADLESS_NOTEBOOK),
}


def test_commands_are_read_as_written():
    md = "\n".join(
        [
            "python -m harness +env=s2d   # prose, not a block",
            "```bash",
            "E=examples/x      # a variable: no command",
            "PYTHONPATH=$E python -m harness +env=s2d   +planner=a  # a comment",
            "python -m harness.data scale=paper \\",
            "    shards=2 -m 'shard=range(0,2)'",
            "srun -p cpu -c 32 python -m harness.data merge=true",
            'pip install -e ".[x]" && python -m harness +env=c2d',
            "# python -m harness +env=commented",
            "rerun some.rrd",
            "```",
            "```json",
            '{"python -m harness": 1}',
            "```",
            "```",
            "MPNET_FIGURE=f.png jupyter execute nb.ipynb",
            "```",
        ]
    )
    assert commands_in(md) == [
        "PYTHONPATH=$E python -m harness +env=s2d +planner=a",
        "python -m harness.data scale=paper shards=2 -m 'shard=range(0,2)'",
        "srun -p cpu -c 32 python -m harness.data merge=true",
        'pip install -e ".[x]"',
        "python -m harness +env=c2d",
        "MPNET_FIGURE=f.png jupyter execute nb.ipynb",
    ]
    needs = dict(required_mentions("PYTHONPATH=$E python -m harness -m +env=s2d,c2d +planner=p x=$Y [seed=N] --o d"))
    assert set(needs) == {
        "module harness",
        "environment variable PYTHONPATH",
        "-m (a sweep)",
        "+env=",
        "one of +env=s2d,c2d",
        "+planner=p",
        "x=",
        "--o",
    }


def test_every_documented_command_is_run_by_a_test():
    missing = [f"{file}: {command}" for file, command in documented_commands() if command not in {**TESTED, **UNTESTED}]
    assert not missing, "documented commands that no test runs (add one to TESTED, or drop the line):\n" + "\n".join(
        missing
    )


def test_every_registered_test_exists():
    gone = [f"{command} -> {test}" for command, test in TESTED.items() if source_of_test(test) is None]
    assert not gone, "TESTED names tests that do not exist:\n" + "\n".join(gone)


def test_each_test_names_its_commands_module_and_overrides():
    bad = []
    for command, test in TESTED.items():
        source = source_of_test(test)
        if source is None:
            continue  # test_every_registered_test_exists says so
        absent = [what for what, either in required_mentions(command) if not any(re.search(r, source) for r in either)]
        if absent:
            bad.append(f"{test} does not mention {', '.join(absent)} of: {command}")
    assert not bad, "\n".join(bad)


def test_no_entry_outlives_its_command():
    documented = {command for _, command in documented_commands()}
    stale = [c for c in [*TESTED, *UNTESTED] if c not in documented]
    assert not stale, "TESTED/UNTESTED entries no page documents any more:\n" + "\n".join(stale)
    assert not set(TESTED) & set(UNTESTED)


def _run_by_file(command: str) -> bool:
    """Whether `command`'s stand-in is a repository file with the command as one of its lines."""
    stand_in = UNTESTED.get(command, ("", ""))[1]
    if not re.fullmatch(r"[\w.-]+(?:/[\w.-]+)+", stand_in) or not (REPO / stand_in).is_file():
        return False
    return command in {" ".join(line.split()) for line in (REPO / stand_in).read_text().splitlines()}


def test_each_untested_command_has_a_stand_in_that_runs():
    pages: dict[str, set[str]] = {}
    for file, command in documented_commands():
        pages.setdefault(command, set()).add(file)
    bad = []
    for command, (why, stand_in) in UNTESTED.items():
        assert why, command
        if _run_by_file(command):
            continue
        shared = pages.get(command, set()) & pages.get(stand_in, set())
        if not shared:
            bad.append(f"{command}: its stand-in is neither a file running it nor a command of its page: {stand_in}")
        elif stand_in not in TESTED and not _run_by_file(stand_in):
            bad.append(f"{command}: its stand-in is run by no test: {stand_in}")
    assert not bad, "\n".join(bad)


def test_the_cluster_extra_is_in_the_dev_extra():
    """`pip install -e ".[cluster]"` installs nothing the suite (installed with dev) lacks."""
    extras = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert set(extras["cluster"]) <= set(extras["dev"])
