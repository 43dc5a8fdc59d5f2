"""The data stage: expert paths, the dataset on disk, the artifact cache."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from mpnet.data.expert import expert_paths
from mpnet.data.store import ArtifactError, content_key, ensure, read_manifest
from mpnet.envs import get_spec
from mpnet.envs.scenes.generators import make_workspace
from mpnet.motion import verify_path


@pytest.mark.slow  # spawned expert processes, one per chunk
@pytest.mark.parametrize("env", ["s2d", "rigid"])
def test_expert_paths_valid_and_reproducible(env):
    spec = get_spec(env)
    wss = [(i, make_workspace(spec, i, "train")) for i in range(2)]
    a = expert_paths(spec, wss, 4, seed=3, iterations=300, max_seconds=2.0, jobs=2)
    b = expert_paths(spec, wss, 4, seed=3, iterations=300, max_seconds=2.0, jobs=1)
    assert len(a) == 8 and np.array_equal(a.states, b.states) and np.array_equal(a.workspace, [0] * 4 + [1] * 4)
    for i in range(len(a)):
        p = a.path(i)
        assert verify_path(spec, wss[a.workspace[i]][1], p, p[0], p[-1]) is None
        assert len(p) >= 3  # blocked_only: the straight line start -> goal is blocked, as in the test queries
        assert not np.any(np.all(p[1:] == p[:-1], axis=1))  # no state repeats the one before it
    np.testing.assert_array_equal(a.cost, a.raw_cost)  # raw RRT* paths: stored as planned
    c = expert_paths(spec, wss, 4, seed=3, iterations=300, max_seconds=2.0, jobs=2, contract=True)
    assert len(c) == 8 and np.all(c.cost <= c.raw_cost + 1e-9) and np.array_equal(c.raw_cost, a.raw_cost)
    assert len(c.states) < len(a.states) == a.raw_states == c.raw_states  # contraction drops states


def test_a_chunk_plans_its_paths_with_either_pairs_in_process():
    """chunk_worker's options reach workspace_paths by name (a positional slip once made
    every chunk plan nothing: `contract` landed in `max_tries`); paths kept by the judge's
    re-check or the planning checker's pass the judge."""
    from mpnet.data.expert import chunk_worker

    spec = get_spec("s2d")
    wss = [(0, make_workspace(spec, 0, "train"))]
    for pairs in ("env", "uniform"):
        for check in ("judge", "planner"):
            options = {"iterations": 200, "max_seconds": 1.0, "contract": True, "pairs": pairs, "check": check}
            got = chunk_worker((spec, wss, 3, 5, 0, options))
            assert len(got) == 3 and np.all(got.cost <= got.raw_cost + 1e-9)
            assert all(verify_path(spec, wss[0][1], p, p[0], p[-1]) is None for p in got.paths())


def test_dedupe_drops_repeated_states_only():
    from mpnet.data.expert import dedupe

    assert dedupe([[0, 0], [0, 0], [1, 0], [1, 0], [0, 0]]) == [[0, 0], [1, 0], [0, 0]]


def test_store_builds_once_and_checks_manifest(tmp_path):
    calls = []

    def build(folder):
        calls.append(folder)
        (folder / "x.txt").write_text("hi")
        return {"files": ["x.txt"]}

    f1, m1, built1 = ensure(tmp_path, "thing", {"a": 1}, build)
    f2, m2, built2 = ensure(tmp_path, "thing", {"a": 1}, build)
    assert built1 and not built2 and f1 == f2 and len(calls) == 1
    assert m1["key"] == content_key({"kind": "thing", "a": 1}) and "created_at" in m1
    f3, _, built3 = ensure(tmp_path, "thing", {"a": 2}, build)
    assert built3 and f3 != f1
    (f1 / "x.txt").unlink()
    with pytest.raises(ArtifactError, match="missing"):
        read_manifest(f1, m1["key"])
    _, _, rebuilt = ensure(tmp_path, "thing", {"a": 1}, build)  # a damaged artifact is rebuilt
    assert rebuilt and (f1 / "x.txt").exists()


def test_failed_build_leaves_nothing(tmp_path):
    def build(folder):
        (folder / "half").write_text("x")
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError):
        ensure(tmp_path, "thing", {"a": 1}, build)
    assert [p.name for p in (tmp_path / "thing").iterdir() if not p.name.endswith(".lock")] == []


def test_store_clears_the_temp_folder_of_a_killed_builder(tmp_path):
    """A builder killed outright (SIGKILL) leaves its temp folder; the next build removes it."""
    key = content_key({"kind": "thing", "a": 1})
    stale = tmp_path / "thing" / f".{key}.tmp-deadbeef"
    stale.mkdir(parents=True)
    (stale / "half").write_text("x")

    def build(folder):
        (folder / "x.txt").write_text("hi")
        return {"files": ["x.txt"]}

    folder, _, built = ensure(tmp_path, "thing", {"a": 1}, build)
    assert built and not stale.exists() and (folder / "x.txt").exists()


@pytest.mark.slow
def test_data_cli_builds_once_under_concurrency(tmp_path, repo):
    """Two jobs asking for the same dataset at once: one builds, the other waits and reuses."""
    cmd = [
        sys.executable,
        "-m",
        "harness.data",
        "+env=s2d",
        "scale=tiny",
        "progress=false",
        f"cache_dir={tmp_path}",
        f"hydra.run.dir={tmp_path / 'run'}",
    ]
    procs = [
        subprocess.Popen(cmd, cwd=repo, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)
    ]
    outs = [p.communicate(timeout=600) for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    firsts = sorted(o[0].splitlines()[0].split(":")[0] for o in outs)
    assert firsts == ["built", "cached"]
    folders = [d for d in (tmp_path / "data").iterdir() if d.is_dir()]
    assert len(folders) == 1
    manifest = json.loads((folders[0] / "manifest.json").read_text())
    assert manifest["config"]["env"] == "s2d" and manifest["expert"]["paths"] == 20
    assert {"git_rev", "versions", "created_at"} <= set(manifest)
    with np.load(folders[0] / "data.npz") as z:
        assert z["train_clouds"].shape == (2, 1400, 2) and z["ae_clouds"].shape == (20, 1400, 2)
        assert z["path_offsets"][-1] == len(z["path_states"])


@pytest.mark.slow  # builds a c3d test set with planned references
def test_cached_testset_is_the_generated_one(tmp_path, settings):
    """The data stage's test set (problem files in the cache) holds exactly the queries the
    generator makes, with their splits; a second call reads the cache."""
    from harness.artifacts.ensure import ensure_testset
    from mpnet.data.queries import make_testset

    run = settings(["+env=c3d", "+planner=bit_star", "scale=tiny", f"cache_dir={tmp_path}"])
    spec = get_spec("c3d")
    got = ensure_testset(run, progress=False)
    want = make_testset(spec, {"seen": (2, 2), "unseen": (2, 2)}, 0, run.env.solvable_s)
    assert [(w.id, w.split) for w in got.workspaces] == [(w.id, w.split) for w in want.workspaces]
    for a, b in zip(got.workspaces, want.workspaces):
        assert np.array_equal(a.centers, b.centers) and np.array_equal(a.sizes, b.sizes)
    assert [(q.id, q.workspace_id, q.split) for q in got.queries] == [
        (q.id, q.workspace_id, q.split) for q in want.queries
    ]
    assert all(
        np.array_equal(a.start, b.start) and np.array_equal(a.goal, b.goal) for a, b in zip(got.queries, want.queries)
    )
    # every query carries its planned reference cost, at least the straight-line distance
    assert all(
        q.reference_cost is not None and q.reference_cost >= np.linalg.norm(q.goal - q.start) - 1e-9
        for q in got.queries
    )
    (folder,) = (tmp_path / "testset").glob("*/")
    assert read_manifest(folder, folder.name)["queries"] == {"seen": 4, "unseen": 4}
    stamp = (folder / "seen.json").stat().st_mtime_ns
    ensure_testset(run, progress=False)
    assert (folder / "seen.json").stat().st_mtime_ns == stamp


@pytest.mark.slow  # spawned expert processes, one per chunk
def test_expert_build_cut_short_resumes_from_its_finished_chunks(tmp_path):
    """Finished chunks are kept; a rerun plans only the missing ones; a damaged one is redone."""
    spec = get_spec("s2d")
    wss = [(i, make_workspace(spec, i, "train")) for i in range(3)]
    args = dict(seed=3, iterations=200, max_seconds=2.0, jobs=1)
    full = expert_paths(spec, wss, 2, resume_dir=tmp_path, **args)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["chunk_0.npz", "chunk_1.npz", "chunk_2.npz"]
    with np.load(tmp_path / "chunk_0.npz") as z:  # mark chunk 0: a resumed build must reuse it as it is
        marked = {k: z[k] for k in z.files}
    marked["cost"] = marked["cost"] + 1000.0
    np.savez(tmp_path / "chunk_0.npz", **marked)
    (tmp_path / "chunk_1.npz").unlink()  # never finished
    whole = (tmp_path / "chunk_2.npz").read_bytes()
    (tmp_path / "chunk_2.npz").write_bytes(whole[: len(whole) // 2])  # cut off mid-write
    done = []
    again = expert_paths(spec, wss, 2, resume_dir=tmp_path, progress=done.append, **args)
    assert sum(done) == 3 and np.allclose(again.cost[:2], full.cost[:2] + 1000.0)
    assert np.array_equal(again.states, full.states) and np.allclose(again.cost[2:], full.cost[2:])


def test_partial_pieces_are_removed_once_the_artifact_is_built(tmp_path):
    from mpnet.data.store import partial_dir

    piece = partial_dir(tmp_path, "thing", {"a": 1})
    piece.mkdir(parents=True)
    (piece / "chunk_0.npz").write_bytes(b"x")

    def build(folder):
        assert piece.exists()  # the build may read its pieces
        (folder / "f").write_text("1")
        return {"files": ["f"]}

    ensure(tmp_path, "thing", {"a": 1}, build)
    assert not piece.exists()


@pytest.mark.slow  # RRT* and RRT-Connect planned to their ends, about 10 s
def test_expert_runs_ended_by_the_clock_are_counted_and_kept_through_chunks(tmp_path):
    """A run that max_seconds ends, not its own count, makes the paths depend on the machine's
    speed (two builds of one key differed so: FINDINGS, issue 42): each expert counts them, a
    chunk keeps the count, and the build's summary says it; RRT* stopped by its iterations,
    RRT-Connect runs that find their path: none."""
    from mpnet.data.expert import _load_chunk, save_chunk, summary, workspace_paths
    from mpnet.data.expert_planners import rrt_connect_path, rrt_star_path

    spec = get_spec("s2d")
    ws = make_workspace(spec, 0, "train")
    checker = spec.make_checker(ws)
    start, goal = (-18.0, -18.0), (18.0, 18.0)
    assert checker.is_valid(list(start)) and checker.is_valid(list(goal))
    clock = []
    rrt_star_path(spec, checker, start, goal, 50, 30.0, clock)
    assert clock == []  # 50 iterations end long before 30 s
    rrt_star_path(spec, checker, start, goal, 10**9, 0.05, clock)
    assert clock == [1]  # a billion iterations do not: the clock did
    assert rrt_connect_path(spec, checker, start, goal, 2, 30.0, clock) is not None and clock == [1]
    got = workspace_paths(spec, ws, 0, 2, 3, iterations=10**9, max_seconds=0.02)
    assert got.clock_stops > 0 and summary(got)["runs_ended_by_clock"] == got.clock_stops
    save_chunk(tmp_path, 0, got)
    assert _load_chunk(tmp_path, 0).clock_stops == got.clock_stops
    quick = workspace_paths(spec, ws, 0, 2, 3, iterations=100, max_seconds=30.0)
    assert quick.clock_stops == 0 and summary(quick)["runs_ended_by_clock"] == 0


@pytest.mark.slow  # two expert builds of 5,000-iteration runs: seconds each
@pytest.mark.parametrize("planner", ["rrt_connect", "rrt_connect_compiled"])
def test_an_rrt_connect_expert_on_an_iteration_budget_is_the_same_on_any_clock(planner):
    """With run_iterations the clock ends no RRT-Connect run (a 2 s clock made two builds of one
    key differ: FINDINGS, issue 42): the same paths with a 30 s and a 1 ns max_seconds, no
    clock stops; a budget too small to connect finds no path, and that is no clock stop. For
    OMPL's RRT-Connect and the compiled one alike."""
    from mpnet.data.expert_planners import EXPERTS

    spec = get_spec("s2d")
    wss = [(i, make_workspace(spec, i, "train")) for i in range(2)]
    args = dict(planner=planner, jobs=1, run_iterations=5000, contract=True)
    slow, fast = (expert_paths(spec, wss, 3, 5, 2, s, **args) for s in (30.0, 1e-9))
    assert len(slow) == 6 and slow.clock_stops == fast.clock_stops == 0
    assert np.array_equal(slow.states, fast.states) and np.array_equal(slow.offsets, fast.offsets)
    ws = wss[0][1]
    checker = spec.make_checker(ws)
    clock = []
    start, goal = (-18.0, -18.0), (18.0, 18.0)  # 36 apart, the straight line blocked
    assert not checker.motion_valid(list(start), list(goal))
    # no iteration at all (RRT-Connect's connect step can cross s2d in one): no path, and no clock stop
    assert EXPERTS[planner](spec, checker, start, goal, 2, 1e-9, clock, run_iterations=0) is None and clock == []


def test_the_compiled_expert_plans_the_arm_as_the_recipe_says_whatever_ompls_seed():
    """The compiled expert on panda_mbm (MBM-style queries of one training scene, the env's
    recipe: the best of 3 runs, each rope-shortcut and contracted): every path passes the
    planning checker and starts and ends at its query; its stream is each query's own, so
    OMPL's RNG seed (which its rope shortcut does not draw from either) changes nothing; a
    process of its own (a chunk) plans the same paths as this one."""
    from ompl import util as ou

    from mpnet.data.expert import chunk_worker, planner_check, workspace_paths

    spec = get_spec("panda_mbm")
    ws = spec.generator.make(0, "train", 0)
    options = dict(iterations=3, max_seconds=2.0, blocked_only=False, contract=True, check="planner")
    options |= dict(planner="rrt_connect_compiled", run_iterations=2000)
    got = []
    for seed in (1, 2):
        ou.RNG.setSeed(seed)
        got.append(workspace_paths(spec, ws, 0, 3, 0, **options))
    a, b = got
    assert len(a) == 3 and np.array_equal(a.states, b.states) and np.array_equal(a.offsets, b.offsets)
    checker = spec.make_checker(ws)
    for p in a.paths():
        assert planner_check(spec, ws, checker, p, p[0], p[-1])
    assert np.all(a.cost <= a.raw_cost + 1e-9)
    c = chunk_worker((spec, [(0, ws)], 3, 0, 0, options))
    assert np.array_equal(c.states, a.states)


def _pid(_args) -> int:
    return os.getpid()


@pytest.mark.slow  # four spawned processes
def test_fresh_processes_are_one_per_task_and_workers_otherwise():
    """in_processes: a fresh process per task (an expert seeding OMPL's process-wide RNG per
    chunk needs one), or, fresh=False, workers that run task after task."""
    from mpnet.data.expert import in_processes

    for fresh, pids in ((True, 3), (False, 1)):
        got: dict[int, int] = {}
        in_processes(_pid, {k: () for k in range(3)}, 1, got.__setitem__, fresh)
        assert sorted(got) == [0, 1, 2] and len(set(got.values())) == pids and os.getpid() not in got.values()


@pytest.mark.slow  # a spawned expert process
def test_the_compiled_experts_chunks_share_a_worker_and_plan_what_each_plans_alone():
    """The compiled expert draws nothing from OMPL's process-wide RNG (PROCESS_SEEDED): its chunks
    run one after another in one long-lived worker and give the paths each chunk gives alone."""
    from mpnet.data.expert import chunk_worker
    from mpnet.data.expert_planners import PROCESS_SEEDED

    assert "rrt_connect_compiled" not in PROCESS_SEEDED and "rrt_connect" in PROCESS_SEEDED
    spec = get_spec("s2d")
    wss = [(i, make_workspace(spec, i, "train")) for i in range(3)]
    options = {"iterations": 2, "max_seconds": 1.0, "contract": True, "planner": "rrt_connect_compiled",
               "run_iterations": 2000}  # fmt: skip
    kw = {k: v for k, v in options.items() if k not in ("iterations", "max_seconds")}
    pooled = expert_paths(spec, wss, 3, seed=4, iterations=2, max_seconds=1.0, jobs=1, chunk_size=1, **kw)
    alone = [chunk_worker((spec, [w], 3, 4, k, options)) for k, w in enumerate(reversed(wss))][::-1]
    assert len(pooled) == sum(map(len, alone)) > 0
    assert np.array_equal(pooled.states, np.concatenate([a.states for a in alone]))
